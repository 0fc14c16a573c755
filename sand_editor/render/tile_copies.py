"""The tile laid as varied copies: facts shared by ``shaders/tile_variation.glsl`` (compiled with
them as #defines) and the glTF export's varied tiles (``export/variation.py``)."""

from __future__ import annotations

TILE_COPY_SPACING = 0.85  # tiles between neighbouring vertices: a hexagon < 1 tile
TILE_COPY_BIAS = 3.0  # a point's weight for its vertex, against a grain's rank (at level 0)

SHADER_DEFINES = {
    "TILE_COPY_SPACING": repr(TILE_COPY_SPACING),
    "TILE_COPY_BIAS": repr(TILE_COPY_BIAS),
}
