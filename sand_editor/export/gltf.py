"""A sand patch as a glTF 2.0 asset (``sand-editor export``), written by pygltflib.

The patch is a square in the XZ plane (glTF is +Y up, metres), centred at the origin, with
texture coordinates 0–1 across it and ``KHR_texture_transform`` repeating the tile as the
preset's texture scale says; optionally the sand sphere rests on it. The material is glTF's
metallic-roughness model with the maps of :mod:`sand_editor.export.maps`:

- ``baseColorTexture``: sRGB; ``normalTexture``: tangent space, +Y up the image (glTF's);
- one ORM image: occlusion in R (``occlusionTexture``), roughness in G, metallic (0) in B
  (``metallicRoughnessTexture``);
- ``KHR_materials_ior``: the grains' index (quartz 1.458); ``KHR_materials_specular``: the share
  of mirroring facets in the alpha of ``specularTexture``;
- the preset itself in the material's ``extras``: ``Preset.load`` reads the file back; beside
  it the glint model's parameters (``export/glints.py``), for a renderer that draws glints.

What does not carry over: the glints (glTF has no sparkle model), the blend by distance into the
far BRDF, the dune ripples and the backscatter of a half space of grains (see the README).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pygltflib as g

from sand_editor.export.glints import check_finite, glint_parameters
from sand_editor.export.images import encode_bands
from sand_editor.export.maps import MaterialMaps, image_band
from sand_editor.export.sets import ENCODE_THREADS, base_color_image, normal_image, orm_image
from sand_editor.preset import GLTF_EXTRAS_KEY, Preset

FORMATS = ("glb", "gltf")
SPHERE_SEGMENTS = 48
_EXTENSIONS = ["KHR_materials_ior", "KHR_materials_specular", "KHR_texture_transform"]


@dataclass(frozen=True)
class PatchOptions:
    size_m: float = 2.0  # edge of the square patch
    sphere: bool = False  # the sand sphere, radius a fifth of the patch, resting on it
    tiles: int = 1  # tiles across the images, each place a varied copy (export/variation.py)


def _specular_image(maps: MaterialMaps) -> np.ndarray:
    # KHR_materials_specular reads the strength from the alpha; the colour stays white.
    ones = np.ones((*maps.specular.shape, 3), np.float32)
    return np.concatenate([ones, maps.specular[..., None]], axis=-1)


_IMAGES = {
    "basecolor": base_color_image,
    "normal": normal_image(1.0),
    "orm": orm_image,
    "specular": _specular_image,
}


def texture_images(maps: MaterialMaps) -> dict[str, bytes]:
    """The four images of the material, PNG, by role (encoded a map per core, each a band of
    rows at a time)."""

    def encoded(make) -> bytes:
        return encode_bands(image_band(maps, make), maps.size, "png8")[0]

    with ThreadPoolExecutor(max_workers=ENCODE_THREADS) as pool:
        return dict(zip(_IMAGES, pool.map(encoded, _IMAGES.values()), strict=True))


def plane_mesh(size_m: float) -> dict[str, np.ndarray]:
    h = size_m / 2.0
    # u along +x, v along +z: the image's up (−v) is −z, so the bitangent cross(n, t) has w = 1.
    positions = np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    normals = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
    tangents = np.tile(np.array([1, 0, 0, 1], np.float32), (4, 1))
    indices = np.array([0, 2, 1, 0, 3, 2], np.uint32)
    return {"POSITION": positions, "NORMAL": normals, "TANGENT": tangents, "TEXCOORD_0": uv,
            "indices": indices}  # fmt: skip


def sphere_mesh(radius: float, center, segments: int = SPHERE_SEGMENTS) -> dict[str, np.ndarray]:
    """A UV sphere: u around (east from −z), v from the top down; tangents along +u. Seen
    from outside u runs right to left (mirrored), so the bitangent cross(n, t) takes w = −1 to
    point up the image (towards the top)."""
    rings = segments // 2
    u = np.linspace(0.0, 1.0, segments + 1)
    v = np.linspace(0.0, 1.0, rings + 1)
    uu, vv = np.meshgrid(u, v)
    phi, theta = 2.0 * math.pi * uu, math.pi * vv
    normal = np.stack(
        [np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1
    )
    tangent = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], -1)
    positions = normal * radius + np.asarray(center, np.float32)
    count = (rings + 1) * (segments + 1)
    tangents = np.concatenate([tangent.reshape(count, 3), -np.ones((count, 1))], -1)
    triangles = []  # counter-clockwise seen from outside; one triangle per cap quad
    for r in range(rings):
        for k in range(segments):
            a, b = r * (segments + 1) + k, (r + 1) * (segments + 1) + k
            if r == 0:
                triangles += [a, b + 1, b]
            elif r == rings - 1:
                triangles += [a, a + 1, b]
            else:
                triangles += [a, a + 1, b, a + 1, b + 1, b]
    return {
        "POSITION": positions.reshape(count, 3).astype(np.float32),
        "NORMAL": normal.reshape(count, 3).astype(np.float32),
        "TANGENT": tangents.astype(np.float32),
        "TEXCOORD_0": np.stack([uu, vv], -1).reshape(count, 2).astype(np.float32),
        "indices": np.array(triangles, np.uint32),
    }


class _Builder:
    """Buffer views and accessors into one binary blob, 4-byte aligned."""

    def __init__(self) -> None:
        self.gltf = g.GLTF2(asset=g.Asset(version="2.0", generator="Sand Editor"))
        self.blob = bytearray()

    def view(self, data: bytes, target: int | None = None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.gltf.bufferViews.append(
            g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data), target=target)
        )
        self.blob += data
        return len(self.gltf.bufferViews) - 1

    def accessor(self, array: np.ndarray, kind: str, bounds: bool = False) -> int:
        indices = array.dtype == np.uint32
        target = g.ELEMENT_ARRAY_BUFFER if indices else g.ARRAY_BUFFER
        view = self.view(np.ascontiguousarray(array).tobytes(), target)
        extra = {}
        if bounds:
            extra = {"min": array.min(axis=0).tolist(), "max": array.max(axis=0).tolist()}
        self.gltf.accessors.append(
            g.Accessor(
                bufferView=view,
                componentType=g.UNSIGNED_INT if indices else g.FLOAT,
                count=len(array),
                type=kind,
                **extra,
            )
        )
        return len(self.gltf.accessors) - 1

    def primitive(self, mesh: dict[str, np.ndarray], material: int) -> g.Primitive:
        kinds = {"POSITION": g.VEC3, "NORMAL": g.VEC3, "TANGENT": g.VEC4, "TEXCOORD_0": g.VEC2}
        attributes = {
            name: self.accessor(mesh[name], kind, bounds=name == "POSITION")
            for name, kind in kinds.items()
        }
        return g.Primitive(
            attributes=g.Attributes(**attributes),
            indices=self.accessor(mesh["indices"], g.SCALAR),
            material=material,
        )


def _material(name: str, preset: Preset, textures: dict[str, int], repeat, extras) -> g.Material:
    transform = {"KHR_texture_transform": {"scale": [float(repeat[0]), float(repeat[1])]}}

    def info(role: str, cls=g.TextureInfo, **more):
        return cls(index=textures[role], extensions=dict(transform), **more)

    return g.Material(
        name=name,
        pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorTexture=info("basecolor"),
            metallicRoughnessTexture=info("orm"),
            metallicFactor=0.0,
            roughnessFactor=1.0,
        ),
        normalTexture=info("normal", g.NormalMaterialTexture),
        occlusionTexture=info("orm", g.OcclusionTextureInfo),
        extensions={
            "KHR_materials_ior": {"ior": float(preset.shading.grain_ior)},
            "KHR_materials_specular": {
                "specularFactor": 1.0,
                "specularTexture": {"index": textures["specular"], "extensions": dict(transform)},
            },
        },
        extras=extras,
    )


def build_gltf(preset: Preset, maps: MaterialMaps, options: PatchOptions, image_uris=None):
    """The asset and its binary blob; images go into the blob, or by ``image_uris`` (role →
    file name) beside the file."""
    b = _Builder()
    gltf = b.gltf
    gltf.extensionsUsed = list(_EXTENSIONS)
    images = texture_images(maps)
    gltf.samplers = [
        g.Sampler(magFilter=g.LINEAR, minFilter=g.LINEAR_MIPMAP_LINEAR, wrapS=g.REPEAT,
                  wrapT=g.REPEAT)
    ]  # fmt: skip
    roles: dict[str, int] = {}
    for role, data in images.items():
        if image_uris is None:
            gltf.images.append(g.Image(bufferView=b.view(data), mimeType="image/png", name=role))
        else:
            gltf.images.append(g.Image(uri=image_uris[role], name=role))
        gltf.textures.append(g.Texture(sampler=0, source=len(gltf.images) - 1, name=role))
        roles[role] = len(gltf.textures) - 1
    extras = {
        GLTF_EXTRAS_KEY: {
            "preset": preset.to_dict(),
            "albedo_scale": [round(float(c), 6) for c in maps.albedo_scale],
            "texture_size": maps.size // maps.tiles,
            "tiles": maps.tiles,
            "glints": check_finite(glint_parameters(preset, maps.specular, maps.tiles)),
        }
    }
    # The images hold maps.tiles tiles across: they repeat that many times less often.
    repeats = options.size_m * preset.shading.uv_scale / maps.tiles
    gltf.materials.append(_material(preset.name, preset, roles, (repeats, repeats), extras))
    primitives = [b.primitive(plane_mesh(options.size_m), 0)]
    if options.sphere:
        radius = options.size_m / 5.0
        around = 2.0 * math.pi * radius * preset.shading.uv_scale / maps.tiles
        gltf.materials.append(
            _material(f"{preset.name} sphere", preset, roles, (around, around / 2.0), extras)
        )
        primitives.append(b.primitive(sphere_mesh(radius, (0.0, radius, 0.0)), 1))
    gltf.meshes = [g.Mesh(name=preset.name, primitives=primitives)]
    gltf.nodes = [g.Node(mesh=0, name=preset.name)]
    gltf.scenes = [g.Scene(nodes=[0])]
    gltf.scene = 0
    b.blob += b"\0" * (-len(b.blob) % 4)
    return gltf, bytes(b.blob), images


def export_files(preset: Preset, maps: MaterialMaps, out: Path, fmt: str, options) -> dict:
    """The files of the export by name (one for GLB; the .gltf, .bin and images otherwise),
    the .gltf or .glb last."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; allowed {', '.join(FORMATS)}")
    stem = out.stem
    if fmt == "glb":
        gltf, blob, _ = build_gltf(preset, maps, options)
        gltf.buffers = [g.Buffer(byteLength=len(blob))]
        gltf.set_binary_blob(blob)
        return {out.name: b"".join(gltf.save_to_bytes())}
    uris = {role: f"{stem}_{role}.png" for role in ("basecolor", "normal", "orm", "specular")}
    gltf, blob, images = build_gltf(preset, maps, options, image_uris=uris)
    gltf.buffers = [g.Buffer(byteLength=len(blob), uri=f"{stem}.bin")]
    files = {uris[role]: data for role, data in images.items()}
    files[f"{stem}.bin"] = blob
    text = gltf.gltf_to_json(indent="  ")
    files[out.name] = (text + "\n").encode()
    return files
