"""The glint model's numbers for other renderers: what a glTF file's ``extras`` carry and what
Unreal 5's Substrate glints take (``bake --target unreal``'s GlintValue map).

Our glints are the sun mirrored in grain facets (shaders/glint_facets.glsl): on a clear grain,
facets whose edges spread log-uniformly from the largest (``Preset.largest_facet_m``) down to
``FACET_SIZE_RANGE`` times smaller, ``FACETS_PER_LARGEST`` of them in the area of one largest
facet; a texel's share of mirroring facets is the material maps' ``specular`` (glTF's
``KHR_materials_specular`` texture). Density of mirroring facets per unit of a tile's UV area
(one tile per UV unit, as the maps are laid out) is therefore

    density = specular × FACETS_PER_LARGEST / largest_facet_m² × (1 / tiles_per_m)²

and its natural logarithm is the "logarithmic microfacet density" of the real-time glint
models that engines ship (Chermain et al. 2020, Deliot & Belcour 2023, which Unreal's
Substrate ``GlintValue`` input takes with ``GlintUV`` the UV it is measured in): about 5 (sparse
glints) to 25 (dense ones) for those models' materials, 12–15 for our shipped sands.
"""

from __future__ import annotations

import math

import numpy as np

from sand_editor.preset import Preset
from sand_editor.render.material import (
    FACET_SIZE_RANGE,
    FACETS_PER_LARGEST,
    LIGHT_ANGULAR_RADIUS,
)

GLINT_MODEL = "sand-editor facets 1"


def facets_per_tile(preset: Preset) -> float:
    """Facets of a wholly clear (mirroring) texel per unit of a tile's UV area."""
    tile_m = 1.0 / preset.shading.uv_scale
    return FACETS_PER_LARGEST * (tile_m / preset.largest_facet_m) ** 2


def log_density(specular, per_tile: float) -> np.ndarray:
    """ln of mirroring facets per unit of tile UV area, per texel of the ``specular`` map
    (share of mirroring facets; ``per_tile``: :func:`facets_per_tile`); 0 (one facet per
    tile) where none mirror."""
    density = np.asarray(specular, dtype=np.float64) * per_tile
    return np.log(np.maximum(density, 1.0)).astype(np.float32)


def glint_parameters(preset: Preset, specular, tiles: int = 1) -> dict:
    """The glint model's parameters, as the exported glTF's material carries them in
    ``extras.sand_editor.glints`` (JSON numbers), for images ``tiles`` tiles across."""
    share = float(np.mean(specular))
    mean_log = float(log_density(share, facets_per_tile(preset)))
    return {
        "model": GLINT_MODEL,
        "largest_facet_m": preset.largest_facet_m,
        "facet_size_range": FACET_SIZE_RANGE,
        "facets_per_largest": FACETS_PER_LARGEST,
        "facet_roughness_beckmann": preset.shading.facet_roughness,
        "grain_ior": preset.shading.grain_ior,
        "clear_grains": preset.shading.clear_grains,
        "tiles_per_m": preset.shading.uv_scale,
        "facets_per_tile": facets_per_tile(preset),
        "mean_mirroring_share": share,
        "log_microfacet_density": mean_log,
        "tiles_per_image": tiles,
        "per_texel": "ln(max(1, specularTexture.a × facets_per_tile)), per unit of tile area "
        "(the images hold tiles_per_image tiles across)",
        "light_angular_radius": LIGHT_ANGULAR_RADIUS,
        "far_blend": {
            "sigmoid_a": preset.shading.sigmoid_a,
            "sigmoid_b": preset.shading.sigmoid_b,
            "weight": "1 / (1 + exp(-a (distance_m - b)))",
        },
    }


def check_finite(parameters: dict) -> dict:
    """Every number of ``parameters`` finite (JSON has no inf or NaN)."""
    for key, value in parameters.items():
        if isinstance(value, dict):
            check_finite(value)
        elif isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"glint parameter {key} is {value}")
    return parameters
