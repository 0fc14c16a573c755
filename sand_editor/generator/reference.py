"""The float64 numpy evaluation of the grain model: the accuracy oracle for the GL generator.

It follows ``noise.py`` step for step, in double precision, over any set of pixels, so tests and
the benchmark can check a few thousand pixels of a 4096² texture without evaluating all of it.
"""

from __future__ import annotations

import numpy as np

from sand_editor.generator.noise import (
    CAP_FLOOR,
    PROFILE_OFFSET,
    PROFILE_SCALE,
    NoiseConstants,
    grain_appearance,
    pixel_cells,
    point_words,
    unpack_points,
)

# The shader's visiting order (own cell, edges, corners): ties break the same way in both.
_NEIGHBOURS = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)]
_CHUNK = 1 << 18


def _nearest_two(nc: NoiseConstants, layer: int, cx, cy, fx, fy):
    """F1, F2, the offset p − f of the nearest point, and its grain word.

    Points are offered in the shader's order (``_NEIGHBOURS``, then point 0 before 1) with
    strict comparisons, so ties break alike in both backends wherever both compute the tied
    distances exactly; on a tie rounded differently in float32 and float64 (a Voronoi border of a
    jitter-0 lattice) they may pick different, equally near points.
    """
    n = cx.shape[0]
    f1 = np.ones(n)
    f2 = np.ones(n)
    delta1 = np.zeros((n, 2))
    word1 = np.zeros(n, dtype=np.uint32)
    p = nc.period
    for ox, oy in _NEIGHBOURS:
        words = point_words(nc, (cx + ox) % p, (cy + oy) % p, layer)
        positions, depths = unpack_points(words, nc.jitter)
        for k in range(words.shape[1]):
            dx = fx - (positions[:, k, 0] + ox)
            dy = fy - (positions[:, k, 1] + oy)
            f = dx * dx + dy * dy + depths[:, k] * depths[:, k]
            nearest = f < f1
            second = ~nearest & (f < f2)
            f2 = np.where(nearest, f1, np.where(second, f, f2))
            f1 = np.where(nearest, f, f1)
            delta1[nearest, 0] = dx[nearest]
            delta1[nearest, 1] = dy[nearest]
            word1 = np.where(nearest, words[:, k], word1)
    return f1, f2, delta1, word1


def evaluate(nc: NoiseConstants, size: int, xs: np.ndarray, ys: np.ndarray) -> dict:
    """Evaluate the sand at pixel centres (xs, ys) of a size×size texture, in float64.

    Returns ``normal`` (n, 3), ``height`` (n,), ``albedo`` (n, 3) linear, ``glint`` (n,),
    ``layer`` (n,) int8 with −1 in gaps, ``grain`` (n,) uint32 the owning grain's word.
    """
    xs = np.asarray(xs, dtype=np.int64).ravel()
    ys = np.asarray(ys, dtype=np.int64).ravel()
    out = {
        "normal": np.zeros((xs.size, 3)),
        "height": np.zeros(xs.size),
        "layer": np.full(xs.size, -1, dtype=np.int8),
        "grain": np.zeros(xs.size, dtype=np.uint32),
    }
    out["normal"][:, 2] = 1.0
    for start in range(0, xs.size, _CHUNK):
        _evaluate_chunk(
            nc, size, xs[start : start + _CHUNK], ys[start : start + _CHUNK], out, start
        )
    out["albedo"], out["glint"] = grain_appearance(nc, out["layer"], out["grain"])
    return out


def _evaluate_chunk(nc, size, xs, ys, out, offset) -> None:
    cx, fx = pixel_cells(xs, size, nc.period)
    cy, fy = pixel_cells(ys, size, nc.period)
    todo = np.arange(xs.size)
    for layer in range(nc.layers):
        if todo.size == 0:
            break
        f1, f2, delta1, word1 = _nearest_two(nc, layer, cx[todo], cy[todo], fx[todo], fy[todo])
        profile = PROFILE_OFFSET + PROFILE_SCALE * (np.sqrt(f2) - np.sqrt(f1))
        grain = (profile > nc.threshold) & (f1 < nc.grain_reach2)
        owned = todo[grain]
        # The cap of the grain's ball (radius² grain_reach2) around its nearest feature point;
        # with no point within reach (F1 clamped) the offset is 0 and the normal straight up.
        delta = delta1[grain]
        reach2 = nc.grain_reach2
        floor2 = CAP_FLOOR * CAP_FLOOR * reach2
        cap = np.sqrt(np.maximum(reach2 - np.einsum("ij,ij->i", delta, delta), floor2))
        normal = np.column_stack([delta, cap])
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        dst = owned + offset
        out["normal"][dst] = normal
        out["height"][dst] = profile[grain]
        out["layer"][dst] = layer
        out["grain"][dst] = word1[grain]
        todo = todo[~grain]
