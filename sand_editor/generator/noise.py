"""The grain model shared by the numpy reference and the GLSL generator.

Both backends evaluate the same function; this module holds what they share: the integer hash, the
mapping from a preset to noise constants, and the colour tables. It imports numpy only.

The model
---------
Each layer is a tileable 2D Worley noise on a grid of ``period`` cells per tile edge. Every cell
carries two feature points, each at a depth below the texture plane: the texture is a slice
through a slab of grains, so a grain that sits deep appears as a smaller disc. Distances are
3D (in-plane offset and depth) in cell units, clamped at 1 as in the reference; because every cell
is one unit wide, a point outside the 3×3 neighbourhood is at least one unit away and can never
beat the clamp, so the 3×3 search is exact. Two points per cell with depths in [0, 1) give one
feature point per unit volume, the density of the reference's 3D noise, which keeps its grain size,
coverage per layer and gap fraction (measured by ``sand-editor bench generator``).

Per pixel and layer: F1 ≤ F2 are the two smallest squared distances (clamped to 1), the grain
profile is ``n = 0.08 + 0.8·(√F2 − √F1)``, the layer has a grain where ``n > threshold`` and
``F1 < R² = 0.7/(10·roundness)``: the slice lies inside the ball of radius R around the nearest
feature point f. That ball is the grain's shape: its normal is
``normalize(p − f, √(R² − |p − f|²))`` (up over the point, tilting outwards to the rim), so higher
roundness means smaller, rounder grains whose facets face every direction, and low roundness
broad, flatter caps. The first layer from the top with a grain owns the pixel.

Hash
----
Each point has one 32-bit word, ``lowbias32(key ^ lowbias32(seed))`` (Wellons' integer mixer, a
bijection with full avalanche), keyed by cell, layer and point: 8 bits each for x, y, depth and the
grain's glint value; the grain's colour draws on a second mix of that word. Integer arithmetic
makes the sand identical on every machine and in both backends. Positions on a 1/256-cell grid are
far below a pixel even at 4096² (about half a pixel at period 36), and two mixes per cell cost a
third less than fetching a stored 128-bit hash per cell on a CPU rasterizer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sand_editor.colour import srgb_to_linear
from sand_editor.preset import GRAINS_PER_CELL

MAX_LAYERS = 15
PALETTE_SIZE = 4
# Where the two points of a cell sit when jitter is 0: a regular diagonal packing.
POINT_ANCHORS = np.array([[0.25, 0.25], [0.75, 0.75]])
ANCHOR_DEPTH = 0.5
# The reference's profile is 0.1 + 0.8·(√F2 − √F1) and its roundness test 10·r·F1 < 0.81. Its 3D
# slice, with feature points that stray outside its search window, yields slightly sparser grains
# than our exact search for the same numbers, so the two constants are calibrated: with these, the
# top-layer coverage, gap fraction and grain count match the reference's within about 10 % across
# threshold 0.05–0.6 and roundness 0.05–0.8 (``sand-editor bench generator`` measures them).
PROFILE_OFFSET = 0.08
PROFILE_SCALE = 0.8
ROUNDNESS_LIMIT = 0.7
# A grain is the cap of a ball of radius² grain_reach2 around its nearest feature point: its
# normal is (p − f, √(reach² − |p − f|²)) normalised, so its facets face every direction of the
# hemisphere that the slice leaves visible, most of them the sky. The vertical part is kept at
# least this share of the radius (slopes at most about 20, as a grain's rim that the slice grazes).
CAP_FLOOR = 0.05
DARKENING_SLOPE = 0.624
DARKENING_FLOOR = 0.4
UNIT_8 = 1.0 / 256.0
KEY_STRIDE = 16 * GRAINS_PER_CELL  # keys per cell: a point per grain for each of up to 16 layers

_U32 = np.uint32


def lowbias32(x: np.ndarray) -> np.ndarray:
    """Wellons' lowbias32 integer mixer, elementwise on uint32 (wraps modulo 2³² like GLSL)."""
    x = np.asarray(x, dtype=_U32)
    with np.errstate(over="ignore"):  # wrapping is the point; numpy only warns on scalars
        x = x ^ (x >> _U32(16))
        x = x * _U32(0x7FEB352D)
        x = x ^ (x >> _U32(15))
        x = x * _U32(0x846CA68B)
    return x ^ (x >> _U32(16))


@dataclass(frozen=True)
class NoiseConstants:
    """Everything both backends need from a preset's generation parameters."""

    layers: int
    period: int
    seed: int
    threshold: float
    roundness: float
    jitter: float
    base_color: np.ndarray  # (3,) linear RGB
    layer_colors: np.ndarray  # (MAX_LAYERS, PALETTE_SIZE, 3) linear RGB, darkened per layer
    layer_light: np.ndarray  # (MAX_LAYERS,) linear share of the light that reaches each layer
    cumulative_weights: np.ndarray  # (PALETTE_SIZE,) in (0, 1], last exactly 1

    @property
    def seed_key(self) -> int:
        return int(lowbias32(np.array(self.seed, dtype=_U32)))

    @property
    def grain_reach2(self) -> float:
        """F1 bound of a grain set by roundness (10·r·F1 < 0.7); 4 (beyond any F1) at r = 0.

        Rounded to float32 once here, so both backends compare against the very same bound.
        """
        if self.roundness <= ROUNDNESS_LIMIT / 40.0:
            return 4.0
        return float(np.float32(ROUNDNESS_LIMIT / (10.0 * self.roundness)))

    @classmethod
    def from_generation(cls, gen) -> NoiseConstants:
        weights = np.asarray(gen.weights, dtype=np.float64)
        cumulative = np.cumsum(weights) / weights.sum()
        cumulative[-1] = 1.0
        palette = np.array([c.srgb for c in gen.colors], dtype=np.float64)
        layer_index = np.arange(MAX_LAYERS, dtype=np.float64)
        darkening = np.maximum(
            DARKENING_FLOOR, 1.0 - layer_index * gen.layer_darkness * DARKENING_SLOPE
        )
        # Darkening acts on the sRGB-encoded colour, as in the reference, so the look matches it.
        layer_colors = srgb_to_linear(darkening[:, None, None] * palette[None, :, :])
        return cls(
            layers=int(gen.layers),
            period=int(gen.period),
            seed=int(gen.seed),
            threshold=float(gen.threshold),
            roundness=float(gen.roundness),
            jitter=float(gen.jitter),
            base_color=srgb_to_linear(np.array(gen.base_color.srgb)),
            layer_colors=layer_colors,
            layer_light=srgb_to_linear(darkening),
            cumulative_weights=cumulative,
        )


SHADER_DEFINES = {
    "PROFILE_OFFSET": repr(PROFILE_OFFSET),
    "PROFILE_SCALE": repr(PROFILE_SCALE),
    "ANCHOR_DEPTH": repr(ANCHOR_DEPTH),
    "CAP_FLOOR": repr(CAP_FLOOR),
    "KEY_STRIDE": f"{KEY_STRIDE}u",
    **{
        f"ANCHOR{k}": "vec2({!r}, {!r})".format(*(float(c) for c in anchor))
        for k, anchor in enumerate(POINT_ANCHORS)
    },
}


def pixel_cells(index: np.ndarray, size: int, period: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell and position inside it (in [0, 1)) of pixel centres, exactly, from integers.

    The pixel centre (index + ½)/size·period is split with integer arithmetic so that the tile
    wraps exactly at every size and both backends see the same cell.
    """
    numerator = (2 * np.asarray(index, dtype=np.int64) + 1) * period
    denominator = 2 * size
    return numerator // denominator, (numerator % denominator) / denominator


def point_words(nc: NoiseConstants, cx: np.ndarray, cy: np.ndarray, layer: int) -> np.ndarray:
    """The 32-bit words of both points of wrapped cells (cx, cy) of a layer, shape (…, 2)."""
    key = (np.asarray(cy, dtype=_U32) * _U32(nc.period) + np.asarray(cx, dtype=_U32)) * _U32(
        KEY_STRIDE
    ) + _U32(2 * layer)
    seed_key = _U32(nc.seed_key)
    return np.stack([lowbias32(key ^ seed_key), lowbias32((key + _U32(1)) ^ seed_key)], axis=-1)


def unpack_points(words: np.ndarray, jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions in the cell (…, 2 points, 2) and depths (…, 2) of the points' words."""
    byte = _U32(0xFF)
    xy = np.stack([words & byte, (words >> _U32(8)) & byte], axis=-1) * UNIT_8
    depth = ((words >> _U32(16)) & byte) * UNIT_8
    positions = POINT_ANCHORS + jitter * (xy - POINT_ANCHORS)
    depths = ANCHOR_DEPTH + jitter * (depth - ANCHOR_DEPTH)
    return positions, depths


def colour_thresholds(cumulative_weights: np.ndarray) -> np.ndarray:
    """Integer bounds of the 16-bit colour pick: entry k starts where pick ≥ thresholds[k − 1].

    pick/65536 ≥ b exactly when pick ≥ ceil(65536·b), so integer compares give the very choice
    the cumulative weights define, in numpy and in GLSL alike.
    """
    return np.ceil(np.asarray(cumulative_weights[:-1]) * 65536.0).astype(_U32)


def grain_colour_index(grain_word: np.ndarray, cumulative_weights: np.ndarray) -> np.ndarray:
    """Palette entry of grains: a 16-bit pick from the word against the cumulative weights."""
    pick = lowbias32(grain_word) >> _U32(16)
    index = np.zeros(pick.shape, dtype=np.int32)
    for threshold in colour_thresholds(cumulative_weights):
        index += pick >= threshold
    return index


def glint_value(grain_word: np.ndarray) -> np.ndarray:
    return (np.asarray(grain_word, dtype=_U32) >> _U32(24)) * UNIT_8


def grain_appearance(nc: NoiseConstants, layer: np.ndarray, word: np.ndarray):
    """Linear albedo (…, 3) and glint value (…) of pixels from their owning layer and grain word.

    Gaps (layer −1) take the base colour and no glint; only top-layer grains glint. Returns
    float32 arrays (one table look-up per pixel: this runs on every read-back).
    """
    layer = np.asarray(layer)
    table = np.concatenate([nc.base_color[None, :], nc.layer_colors.reshape(-1, 3)])
    colour = grain_colour_index(word, nc.cumulative_weights)
    # Row 0 is the gap colour; layer i, colour k is row 1 + i·PALETTE_SIZE + k.
    row = np.where(layer >= 0, 1 + layer.astype(np.int32) * PALETTE_SIZE + colour, 0)
    albedo = np.take(table.astype(np.float32), row, axis=0)
    glint = np.where(layer == 0, glint_value(word).astype(np.float32), np.float32(0.0))
    return albedo, glint
