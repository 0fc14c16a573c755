"""Texture sets for the engines people use (``sand-editor bake --target``): each engine's
channel packing, normal-map handedness, names and a README saying how to plug the set in.

Every set is made from the same :class:`~sand_editor.export.maps.MaterialMaps`. Normals are
encoded ``n · 0.5 + 0.5`` in every format (EXR too, as linear half floats), +Y up the image
(OpenGL) or −Y (DirectX) as the engine wants; colour maps are sRGB, the others linear.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial

import numpy as np

from sand_editor.export.glints import log_density
from sand_editor.export.images import FORMATS, encode_bands, linear_to_srgb8
from sand_editor.export.maps import MaterialMaps, image_band
from sand_editor.files import file_stem
from sand_editor.preset import Preset

TARGETS = ("gltf", "unity-hdrp", "unreal", "godot")
ENCODE_THREADS = max(1, min(4, os.cpu_count() or 1))


@dataclass(frozen=True)
class MapFormats:
    """The file format of the maps that may be deeper than 8 bits."""

    normal: str = "png8"
    height: str = "png16"

    def __post_init__(self) -> None:
        for name in ("normal", "height"):
            if getattr(self, name) not in FORMATS:
                raise ValueError(
                    f"--{name}-format {getattr(self, name)!r} is unknown; allowed "
                    f"{', '.join(FORMATS)}"
                )


@dataclass(frozen=True)
class _Map:
    suffix: str  # file name after the preset's name
    make: Callable[[MaterialMaps], np.ndarray]
    what: str  # for the README
    deep: str = ""  # "normal" or "height": its format follows MapFormats
    fixed: str = ""  # a format it always has (a map of unbounded floats: "exr")


def normal_image(y_sign: float) -> Callable[[MaterialMaps], np.ndarray]:
    """The normals encoded n · 0.5 + 0.5, +Y up the image (``y_sign`` 1) or down (−1)."""

    def make(maps: MaterialMaps) -> np.ndarray:
        n = maps.normal * np.array([1.0, y_sign, 1.0], np.float32)
        return n * 0.5 + 0.5

    return make


def base_color_image(maps: MaterialMaps) -> np.ndarray:
    """The base colour, sRGB 8-bit codes."""
    return linear_to_srgb8(maps.base_color)


def orm_image(maps: MaterialMaps) -> np.ndarray:
    """Occlusion, roughness and metallic (0) in R, G, B: glTF's and the engines' ORM."""
    return np.stack([maps.occlusion, maps.roughness, np.zeros_like(maps.roughness)], axis=-1)


def _hdrp_mask(maps: MaterialMaps) -> np.ndarray:
    zero, one = np.zeros_like(maps.roughness), np.ones_like(maps.roughness)
    return np.stack([zero, maps.occlusion, one, 1.0 - maps.roughness], axis=-1)


_HEIGHT = _Map("Height", lambda m: m.height, "grain height, 0 (gaps) to 1 (tallest grain top)",
               "height")  # fmt: skip
_NORMAL_GL = "tangent-space normal, OpenGL convention (+Y up the image)"

_SETS: dict[str, tuple[list[_Map], str]] = {
    "gltf": (
        [
            _Map("BaseColor", base_color_image, "base colour, sRGB"),
            _Map("Normal", normal_image(1.0), _NORMAL_GL, "normal"),
            _Map(
                "ORM",
                orm_image,
                "R occlusion, G roughness, B metallic (0): glTF's "
                "occlusionTexture and metallicRoughnessTexture may share it",
            ),
            _Map(
                "Specular",
                lambda m: m.specular,
                "KHR_materials_specular strength "
                "(specularTexture's alpha): the share of light the grain facets mirror",
            ),
            _HEIGHT,
        ],
        "glTF 2.0 (three.js, Babylon.js, Blender's glTF importer; or use sand-editor export "
        "for a ready .glb): baseColorTexture = BaseColor, normalTexture = Normal, "
        "metallicRoughnessTexture and occlusionTexture = ORM, KHR_materials_specular's "
        "specularTexture alpha = Specular, KHR_materials_ior = {ior}.",
    ),
    "unity-hdrp": (
        [
            _Map("BaseMap", base_color_image, "Base Map, sRGB"),
            _Map(
                "MaskMap",
                _hdrp_mask,
                "Mask Map: R metallic (0), G ambient occlusion, "
                "B detail mask (1), A smoothness (1 − roughness)",
            ),
            _Map("Normal", normal_image(1.0), _NORMAL_GL + " as Unity expects", "normal"),
            _HEIGHT,
        ],
        "Unity HDRP Lit shader: Base Map = BaseMap (sRGB), Mask Map = MaskMap (import with "
        "sRGB off), Normal Map = Normal (Texture Type: Normal map), Height Map = Height "
        "(Parametrization: Amplitude). Tiling: {tiles_per_m} per metre.",
    ),
    "unreal": (
        [
            _Map("BaseColor", base_color_image, "Base Color, sRGB"),
            _Map(
                "Normal",
                normal_image(-1.0),
                "tangent-space normal, DirectX convention (−Y up the "
                "image, green flipped) as Unreal expects",
                "normal",
            ),
            _Map("ORM", orm_image, "R ambient occlusion, G roughness, B metallic (0)"),
            _HEIGHT,
            _Map(
                "GlintValue",
                lambda maps: log_density(maps.specular, maps.facets_per_tile),
                "Substrate GlintValue: ln of mirroring facets per unit of the tile's UV area",
                fixed="exr",
            ),
        ],
        "Unreal Engine material: Base Color = BaseColor; Normal = Normal (compression "
        "Normalmap); ORM with sRGB off and compression Masks: R → Ambient Occlusion, "
        "G → Roughness, B → Metallic; Height for displacement or parallax. Specular = "
        "{unreal_specular:.2f} (Unreal's 0.5 is F0 = 0.04; the grains' index {ior} gives "
        "F0 = {f0:.3f}). Glints (Substrate, r.Substrate.Glints=1): a Substrate Slab's "
        "Glint Value = GlintValue (float EXR, sRGB off, no compression: HDR), Glint UV = "
        "TexCoord[0] (one tile per UV unit), Roughness as above.",
    ),
    "godot": (
        [
            _Map("Albedo", base_color_image, "albedo, sRGB"),
            _Map("Normal", normal_image(1.0), _NORMAL_GL + " as Godot expects", "normal"),
            _Map("ORM", orm_image, "R ambient occlusion, G roughness, B metallic (0)"),
            _HEIGHT,
        ],
        "Godot 4 ORMMaterial3D: Albedo texture = Albedo, ORM texture = ORM, Normal Map = Normal "
        "(import as normal map), Height = Height (Heightmap, deep parallax). UV1 scale "
        "{tiles_per_m} per metre of mesh.",
    ),
}


def _encode_map(maps: MaterialMaps, entry: _Map, fmt: str) -> tuple[bytes, str]:
    # Normals in EXR as half floats (engines' own choice for them); heights as full floats.
    half = entry.deep == "normal"
    return encode_bands(image_band(maps, entry.make), maps.size, fmt, half=half)


def texture_set(
    preset: Preset, maps: MaterialMaps, target: str, formats: MapFormats, stem: str
) -> dict[str, bytes]:
    """The files of a target's set by name, README last; the maps' names start with ``stem``
    made a safe file stem (:func:`~sand_editor.files.file_stem`: it is the preset's name, which
    a downloaded file may carry)."""
    if target not in _SETS:
        raise ValueError(f"unknown target {target!r}; allowed {', '.join(TARGETS)}")
    stem = file_stem(stem)
    entries, how = _SETS[target]
    files: dict[str, bytes] = {}
    lines = []
    chosen = [
        entry.fixed or (getattr(formats, entry.deep) if entry.deep else "png8") for entry in entries
    ]
    # The encoders spend their time in zlib, which lets other threads run: one map per core.
    with ThreadPoolExecutor(max_workers=ENCODE_THREADS) as pool:
        encoded = list(pool.map(partial(_encode_map, maps), entries, chosen))
    for entry, fmt, (data, extension) in zip(entries, chosen, encoded, strict=True):
        name = f"{stem}_{entry.suffix}{extension}"
        files[name] = data
        depth = {"png8": "8-bit PNG", "png16": "16-bit PNG", "exr": "float EXR"}[fmt]
        if fmt == "exr" and entry.deep == "normal":
            depth = "half-float EXR"
        lines.append(f"- {name} ({depth}): {entry.what}")
    ior = preset.shading.grain_ior
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    text = how.format(
        ior=f"{ior:g}",
        f0=f0,
        unreal_specular=f0 / 0.08,
        tiles_per_m=f"{preset.shading.uv_scale:g} tiles",
    )
    readme = [
        f"{preset.name}: a Sand Editor texture set for {target}",
        "",
        f"One tileable {maps.size}x{maps.size} tile; the preset repeats it "
        f"{preset.shading.uv_scale:g} times per metre.",
        "",
        *lines,
        "",
        "How to use it:",
        text,
        "",
        "The base colour is the grains' albedo scaled to the light the sand reflects from afar "
        f"(x {', '.join(f'{c:.3f}' for c in maps.albedo_scale)} per channel), as an engine's "
        "Lambertian diffuse needs it. Not in the set: the glints (no engine material has the "
        "sparkle model), the blend by distance into the far BRDF, and the dune ripples.",
    ]
    files["README.txt"] = ("\n".join(readme) + "\n").encode()
    return files
