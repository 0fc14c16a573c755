"""The material maps a physically based renderer with a metallic-roughness model takes, made
from a preset's grains: base colour, tangent-space normals, roughness, occlusion, the share of
mirroring facets (glTF's specular) and height. Arrays keep the generator's rows (row 0 at
v = 0); :func:`image_rows` turns them into an image file's, top row first.

What each map holds, and why:

- **base colour**: the grains' albedo scaled, per channel, to the albedo of the Lambertian
  surface that reflects as much sunlight as our far field does
  (``render.far_brdf.lambert_equivalent_albedo``): a half space of grains reflects about half of
  what a Lambertian surface of their albedo would, and an engine's diffuse term is Lambertian;
  divided by the share of light glTF's specular layer leaves to the diffuse under it.
- **roughness**: the width of the far field's specular lobe. A bed of round grains mirrors the
  sun over the whole hemisphere: the grains' slopes (their variance from the normal moments)
  widen the facets' own roughness α to GGX's α_eff = √(α² + 2σ²), and glTF's roughness is
  √α_eff, at most 1 — which a hemispherical bump reaches exactly (its distribution of normals
  is GGX's at α = 1). The facets' sharpness shows only in glints, which glTF cannot carry.
- **specular**: the share of the light a texel's facets mirror (clear grain × the light its
  layer gets), for ``KHR_materials_specular``'s strength.
- **occlusion**: the cavity term of the height: how far a texel lies below the grains around it
  (a box of one grain's width), 1 on the tops.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sand_editor.export.glints import facets_per_tile
from sand_editor.generator import SandTextures
from sand_editor.generator.noise import PROFILE_OFFSET, PROFILE_SCALE, NoiseConstants
from sand_editor.preset import Preset
from sand_editor.render.far_brdf import grain_tilts, lambert_equivalent_albedo

PROFILE_TOP = PROFILE_OFFSET + PROFILE_SCALE  # the tallest a grain's height gets
OCCLUSION_STRENGTH = 1.0
# Rows per band where a map is made a band at a time (even, for the half-resolution mean):
# whole-tile temporaries in float64 would take gigabytes at 4096².
BAND_ROWS = 256


def _bands(rows: int):
    return (slice(start, min(start + BAND_ROWS, rows)) for start in range(0, rows, BAND_ROWS))


@dataclass(frozen=True)
class MaterialMaps:
    """One tile's maps, float32, rows as the generator's (row 0 at v = 0). ``normal`` may be
    the grain textures' own array, and ``roughness``, one value for the tile, a read-only
    broadcast of it."""

    base_color: np.ndarray  # (n, n, 3) linear
    normal: np.ndarray  # (n, n, 3) unit, tangent space, +z out of the surface, +y along +v
    roughness: np.ndarray  # (n, n) glTF roughness
    specular: np.ndarray  # (n, n) share of mirrored light
    occlusion: np.ndarray  # (n, n) 0 (hidden) to 1 (open)
    height: np.ndarray  # (n, n) 0 to 1: the grain profile over its tallest
    albedo_scale: np.ndarray  # (3,) base colour over grain albedo
    facets_per_tile: float = 0.0  # facets of a wholly mirroring texel per tile (export/glints.py)
    tiles: int = 1  # tiles across the maps (export/variation.py lays out several)

    @property
    def size(self) -> int:
        return int(self.base_color.shape[0])

    def rows(self, band: slice) -> MaterialMaps:
        """These maps' rows ``band`` (views, no copies)."""
        return MaterialMaps(
            self.base_color[band], self.normal[band], self.roughness[band], self.specular[band],
            self.occlusion[band], self.height[band], self.albedo_scale, self.facets_per_tile,
            self.tiles,
        )  # fmt: skip


def clear_weights(preset: Preset, textures: SandTextures) -> np.ndarray:
    """Each texel's share of mirroring facets: the light its layer gets on a clear grain."""
    constants = NoiseConstants.from_generation(preset.generation)
    weights = np.empty(textures.layer.shape, np.float32)
    for band in _bands(len(weights)):
        layer = textures.layer[band]
        glint_value = (textures.grain_id[band] >> np.uint32(24)).astype(np.float64) / 256.0
        light = constants.layer_light[np.clip(layer, 0, None).astype(np.int64)]
        clear = (layer >= 0) & (glint_value < preset.shading.clear_grains)
        weights[band] = np.where(clear, light, 0.0)
    return weights


def _box_mean_periodic(values: np.ndarray, radius: int) -> np.ndarray:
    """The mean over a (2r+1)² box, wrapping at the tile's edges (it tiles), by running sums."""
    width = 2 * radius + 1
    out = values.astype(np.float64)
    for axis in (0, 1):
        pad = [(0, 0), (0, 0)]
        pad[axis] = (radius + 1, radius)
        sums = np.cumsum(np.pad(out, pad, mode="wrap"), axis=axis)
        ahead = np.take(sums, np.arange(width, width + out.shape[axis]), axis=axis)
        behind = np.take(sums, np.arange(out.shape[axis]), axis=axis)
        out = (ahead - behind) / width
    return out


def occlusion_map(height: np.ndarray, grain_px: float) -> np.ndarray:
    """Cavity occlusion: 1 − (how far a texel lies below its surroundings' mean height) over the
    tallest profile, the surroundings a box one grain across. The box's mean is smooth, so on
    big tiles it is taken at half the resolution (a quarter of the work) and spread back."""
    radius = max(1, int(round(grain_px / 2.0)))
    n = height.shape[0]
    halved = radius >= 8 and n % 2 == 0
    if halved:
        half = height.reshape(n // 2, 2, n // 2, 2).mean(axis=(1, 3), dtype=np.float64)
        mean = _box_mean_periodic(half, radius // 2)
    else:
        mean = _box_mean_periodic(height, radius)
    occlusion = np.empty(height.shape, np.float32)
    for band in _bands(n):
        if halved:
            around = mean[band.start // 2 : band.stop // 2]
            around = np.repeat(np.repeat(around, 2, axis=0), 2, axis=1)
        else:
            around = mean[band]
        below = np.maximum(around - height[band], 0.0)
        occlusion[band] = np.clip(1.0 - OCCLUSION_STRENGTH * below / PROFILE_TOP, 0.0, 1.0)
    return occlusion


def albedo_scale(preset: Preset, textures: SandTextures, moments=None) -> np.ndarray:
    """Per channel, the Lambertian-equivalent albedo of the tile over its mean albedo (the far
    range's light, the grains' tilts correcting its five normals)."""
    kd = np.clip(textures.average_albedo.astype(np.float64), 1e-4, 1.0)
    moments = normal_moments(textures.normal) if moments is None else moments
    tilts = grain_tilts(textures.normal[..., :2])
    return lambert_equivalent_albedo(preset, kd, moments, tilts) / kd


def normal_moments(normal: np.ndarray) -> tuple[float, float, float, float]:
    """The tile's mean nx, ny and mean nx², ny²: the top level of the material's normal
    moments (material_build.frag), which the far field shades with."""
    xy = normal[..., :2]
    mean = xy.mean(axis=(0, 1), dtype=np.float64)
    square = np.square(xy).mean(axis=(0, 1), dtype=np.float64)
    return float(mean[0]), float(mean[1]), float(square[0]), float(square[1])


def far_roughness(preset: Preset, moments) -> float:
    """glTF's roughness of the far field's specular lobe (see the module's notes)."""
    mx, my, sx, sy = moments
    # Unit normals' (nx, ny) moments to slopes' variance: a slope is n_xy / n_z, and
    # E[n_xy²] / E[n_z²] estimates it without dividing texel by texel.
    nz2 = max(1.0 - sx - sy, 1e-3)
    slope_variance = 0.5 * (sx - mx * mx + sy - my * my) / nz2
    alpha = preset.shading.facet_roughness
    alpha_eff = math.sqrt(alpha * alpha + 2.0 * slope_variance)
    return math.sqrt(min(alpha_eff, 1.0))


def dielectric_f0(ior: float) -> float:
    """Normal-incidence reflectance of a dielectric of index ``ior`` in air."""
    return ((ior - 1.0) / (ior + 1.0)) ** 2


def mean_fresnel(ior: float) -> float:
    """Schlick's Fresnel averaged over a hemisphere of directions, cosine-weighted:
    F0 + (1 − F0) · 2∫(1 − μ)⁵ μ dμ = F0 + (1 − F0) / 21."""
    f0 = dielectric_f0(ior)
    return f0 + (1.0 - f0) / 21.0


def material_maps(preset: Preset, textures: SandTextures) -> MaterialMaps:
    moments = normal_moments(textures.normal)
    scale = albedo_scale(preset, textures, moments)
    clear = clear_weights(preset, textures)
    # glTF layers its diffuse under the specular (fresnel_mix): the diffuse keeps 1 − F of the
    # light, F scaled by the specular strength. Our far field's diffuse is what the grains send
    # back after that loss already, so the base colour makes up for it.
    kept = 1.0 - clear * np.float32(mean_fresnel(preset.shading.grain_ior))
    base = np.multiply(textures.albedo, scale.astype(np.float32), dtype=np.float32)
    base /= kept[..., None]
    del kept
    np.clip(base, 0.0, 1.0, out=base)
    rough = np.broadcast_to(np.float32(far_roughness(preset, moments)), clear.shape)
    grain_px = textures.size / preset.generation.period
    height = np.divide(textures.height, PROFILE_TOP, dtype=np.float32)
    np.clip(height, 0.0, 1.0, out=height)
    return MaterialMaps(
        base_color=base,
        normal=np.asarray(textures.normal, dtype=np.float32),
        roughness=rough,
        specular=clear,
        occlusion=occlusion_map(textures.height, grain_px),
        height=height,
        albedo_scale=scale,
        facets_per_tile=facets_per_tile(preset),
    )


def image_rows(array: np.ndarray) -> np.ndarray:
    """Rows of an image file (top first, v = 1) from the generator's (row 0 at v = 0)."""
    return np.ascontiguousarray(np.flipud(array))


def image_band(maps: MaterialMaps, make):
    """The image ``make(maps)`` as a function of a band of its rows (top first), made from
    those rows of the maps alone: for :func:`~sand_editor.export.images.encode_bands`."""
    n = maps.size

    def band(rows: slice) -> np.ndarray:
        return make(maps.rows(slice(n - rows.stop, n - rows.start)))[::-1]

    return band
