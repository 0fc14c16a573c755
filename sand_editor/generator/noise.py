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
profile is ``n = 0.1 + 0.8·(√F2 − √F1)``, the layer has a grain where ``n > threshold`` and
``10·roundness·F1 < 0.81``. The normal is ``normalize(−∇n, n)`` with the exact gradient
``∇n = 0.8·(∇√F2 − ∇√F1)``, ``∇√F = (p − f)/√F`` (zero where F is clamped or zero). The first layer
from the top with a grain owns the pixel.

Hash
----
One PCG4D hash (Jarzynski & Olano, 2020) per cell and layer gives 128 bits: for each of the two
points, 16 bits each for x, y and depth and 16 bits for the grain value (glint). The grain's colour
draws on a second, 32-bit integer hash of that word. Integer arithmetic makes the sand identical on
every machine and in both backends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

POINTS_PER_CELL = 2
MAX_LAYERS = 15
PALETTE_SIZE = 4
# Where the two points of a cell sit when jitter is 0: a regular diagonal packing.
POINT_ANCHORS = np.array([[0.25, 0.25], [0.75, 0.75]])
ANCHOR_DEPTH = 0.5
PROFILE_OFFSET = 0.1
PROFILE_SCALE = 0.8
ROUNDNESS_LIMIT = 0.81  # (1 − 0.1)², the reference's 1 − (0.1 + √(10·r·F1)) > 0, squared
DARKENING_SLOPE = 0.624
DARKENING_FLOOR = 0.4
UNIT_16 = 1.0 / 65536.0

_U32 = np.uint32


def pcg4d(v: np.ndarray) -> np.ndarray:
    """PCG4D hash of uint32 vectors, shape (..., 4) → (..., 4); wraps modulo 2³² like GLSL."""
    v = np.asarray(v, dtype=_U32).copy()
    x, y, z, w = (v[..., i] for i in range(4))
    x = x * _U32(1664525) + _U32(1013904223)
    y = y * _U32(1664525) + _U32(1013904223)
    z = z * _U32(1664525) + _U32(1013904223)
    w = w * _U32(1664525) + _U32(1013904223)
    x = x + y * w
    y = y + z * x
    z = z + x * y
    w = w + y * z
    x = x ^ (x >> _U32(16))
    y = y ^ (y >> _U32(16))
    z = z ^ (z >> _U32(16))
    w = w ^ (w >> _U32(16))
    x = x + y * w
    y = y + z * x
    z = z + x * y
    w = w + y * z
    return np.stack([x, y, z, w], axis=-1)


def lowbias32(x: np.ndarray) -> np.ndarray:
    """A 32-bit integer mixer (Wellons' lowbias32); picks a grain's colour from its grain word."""
    x = np.asarray(x, dtype=_U32)
    x = x ^ (x >> _U32(16))
    x = x * _U32(0x7FEB352D)
    x = x ^ (x >> _U32(15))
    x = x * _U32(0x846CA68B)
    return x ^ (x >> _U32(16))


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055)


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
    cumulative_weights: np.ndarray  # (PALETTE_SIZE,) in (0, 1], last exactly 1

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
            cumulative_weights=cumulative,
        )


def pixel_cells(index: np.ndarray, size: int, period: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell and position inside it (in [0, 1)) of pixel centres, exactly, from integers.

    The pixel centre (index + ½)/size·period is split with integer arithmetic so that the tile
    wraps exactly at every size and both backends see the same cell.
    """
    numerator = (2 * np.asarray(index, dtype=np.int64) + 1) * period
    denominator = 2 * size
    return numerator // denominator, (numerator % denominator) / denominator


def unpack_points(h: np.ndarray, jitter: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions in the cell (…, 2 points, 2), depths (…, 2) and grain words (…, 2) of a hash.

    Word 2k holds point k's x (low 16 bits) and y (high); word 2k+1 its depth (low) and its grain
    value (high, the glint value; the whole word seeds its colour).
    """
    pos_word = h[..., 0::2]
    grain_word = h[..., 1::2]
    xy = np.stack([pos_word & _U32(0xFFFF), pos_word >> _U32(16)], axis=-1) * UNIT_16
    depth = (grain_word & _U32(0xFFFF)) * UNIT_16
    positions = POINT_ANCHORS + jitter * (xy - POINT_ANCHORS)
    depths = ANCHOR_DEPTH + jitter * (depth - ANCHOR_DEPTH)
    return positions, depths, grain_word


def grain_colour_index(grain_word: np.ndarray, cumulative_weights: np.ndarray) -> np.ndarray:
    pick = (lowbias32(grain_word) >> _U32(16)) * UNIT_16
    index = np.zeros(np.shape(pick), dtype=np.int64)
    for boundary in cumulative_weights[:-1]:
        index += pick >= boundary
    return index


def glint_value(grain_word: np.ndarray) -> np.ndarray:
    return (np.asarray(grain_word, dtype=_U32) >> _U32(16)) * UNIT_16


def grain_appearance(nc: NoiseConstants, layer: np.ndarray, word: np.ndarray):
    """Linear albedo (…, 3) and glint value (…) of pixels from their owning layer and grain word.

    Gaps (layer −1) take the base colour and no glint; only top-layer grains glint.
    """
    layer = np.asarray(layer)
    owned = layer >= 0
    colour = grain_colour_index(word, nc.cumulative_weights)
    albedo = nc.layer_colors[np.where(owned, layer, 0), colour]
    albedo = np.where(owned[..., None], albedo, nc.base_color)
    glint = np.where(layer == 0, glint_value(word), 0.0)
    return albedo, glint
