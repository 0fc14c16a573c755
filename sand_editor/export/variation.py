"""Maps of several tiles, each place a varied copy of the one tile: an engine that repeats the
image (glTF's sampler, any engine's) shows the pattern ``tiles`` tiles apart instead of every
tile, with no seam and no grain cut.

The layout is the renderer's tile variation (``shaders/tile_variation.glsl``) made periodic: a
grid of vertices at about the renderer's spacing, a whole number of them across the image each
way, each with its copy of the tile (one of the square's eight symmetries and a shift by whole
texels, so that every texel is a texel of the tile, exactly). A texel shows its nearest vertex's
copy, except in a band along the edges of the vertices' hexagons, where the copy whose grain
there ranks highest wins: the borders between copies run along grain outlines. The normals are
turned with their copy, so that they stay in the image's tangent frame.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from sand_editor.export.maps import BAND_ROWS, MaterialMaps
from sand_editor.render.tile_copies import TILE_COPY_BIAS, TILE_COPY_SPACING

MAX_TILES = 8
EXPORT_TILES = (1, 2, 4)  # what the editor's Export glTF offers (4: 4096² images at 1024²)
MAX_VARIED_TEXELS = 8192  # texels across the varied images: the size times the tiles
_M64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def check_tiles(tiles, size: int) -> int:
    """``tiles`` as an int, or ``ValueError`` naming what is allowed for maps of ``size``."""
    if isinstance(tiles, bool) or not hasattr(tiles, "__index__"):
        raise ValueError(f"tiles must be an integer from 1 to {MAX_TILES}, got {tiles!r}")
    tiles = tiles.__index__()
    most = min(MAX_TILES, MAX_VARIED_TEXELS // size)
    if not 1 <= tiles <= most:
        raise ValueError(
            f"tiles {tiles} is out of range for texture size {size}; allowed 1 to {most} "
            f"(at most {MAX_VARIED_TEXELS} texels across the images)"
        )
    return tiles


def _mix(x: np.ndarray) -> np.ndarray:
    """A 64-bit integer hash (splitmix64's finaliser), element-wise."""
    x = np.asarray(x, dtype=np.uint64)
    with np.errstate(over="ignore"):
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9) & _M64
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB) & _M64
    return x ^ (x >> np.uint64(31))


def grain_keys(textures) -> np.ndarray:
    """Each texel's grain, as one integer (its layer and identity within the layer)."""
    layer = textures.layer.astype(np.int64) + 1
    return (layer.astype(np.uint64) << np.uint64(32)) | textures.grain_id.astype(np.uint64)


class CopyLayout:
    """Which copy of the tile each texel of a ``tiles``×``tiles`` image shows.

    ``grain_key``: (n, n) an identity per texel of the tile's grains (layer and grain), whose
    hash ranks the copies' grains where they meet."""

    def __init__(self, grain_key: np.ndarray, tiles: int, seed: int = 0) -> None:
        self.n = int(grain_key.shape[0])
        self.tiles = check_tiles(tiles, self.n)
        self.grain_key = np.asarray(grain_key, dtype=np.uint64)
        self.seed = np.uint64(seed & 0xFFFFFFFF)
        # Vertices at ((i + j/2)·sx, j·sy): columns and (pairs of) rows a whole number across.
        self.columns = max(1, round(self.tiles / TILE_COPY_SPACING))
        self.row_pairs = max(1, round(self.tiles / (2.0 * TILE_COPY_SPACING * math.sqrt(0.75))))
        self.sx = self.tiles / self.columns
        self.sy = self.tiles / (2 * self.row_pairs)

    def _vertex_key(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """The hash of vertex (i, j), the same for every vertex the image's period maps onto it."""
        rows = 2 * self.row_pairs
        j0 = np.mod(j, rows)
        i0 = np.mod(i + (j - j0) // 2, self.columns)
        return _mix((i0.astype(np.uint64) << np.uint64(20)) ^ j0.astype(np.uint64) ^ (
            self.seed << np.uint64(40)))  # fmt: skip

    def _source(self, key: np.ndarray, x: np.ndarray, y: np.ndarray):
        """The tile's texel (column, row) that copy ``key`` shows at image texel (x, y), and the
        copy's symmetry: swap, then mirror in x, in y."""
        n = self.n
        swap = (key & np.uint64(1)) != 0
        mirror_x = (key & np.uint64(2)) != 0
        mirror_y = (key & np.uint64(4)) != 0
        shift = _mix(key)
        ox = (shift % np.uint64(n)).astype(np.int64)
        oy = ((shift >> np.uint64(32)) % np.uint64(n)).astype(np.int64)
        a = np.where(swap, y, x)
        b = np.where(swap, x, y)
        sx = np.mod(np.where(mirror_x, ox - 1 - a, a + ox), n)
        sy = np.mod(np.where(mirror_y, oy - 1 - b, b + oy), n)
        return sx, sy, swap, mirror_x, mirror_y

    def rows(self, band: slice):
        """For image rows ``band`` (row 0 at v = 0): :meth:`at` each texel of the rows."""
        y, x = np.mgrid[band, 0 : self.n * self.tiles].astype(np.int64)
        return self.at(x, y)

    def at(self, x: np.ndarray, y: np.ndarray):
        """For image texels (x, y), any integers (the image repeats): the source column and row
        in the tile and the copy's swap and mirrors."""
        px = (x + 0.5) / self.n
        py = (y + 0.5) / self.n
        jf = py / self.sy
        if_ = px / self.sx - 0.5 * jf
        bi, bj = np.floor(if_), np.floor(jf)
        fi, fj = if_ - bi, jf - bj
        bi, bj = bi.astype(np.int64), bj.astype(np.int64)
        lower = fi + fj < 1.0
        # The triangle holding the texel: its three vertices and their barycentric weights.
        vi = np.stack([np.where(lower, bi, bi + 1), np.where(lower, bi + 1, bi),
                       np.where(lower, bi, bi + 1)])  # fmt: skip
        vj = np.stack([np.where(lower, bj, bj + 1), np.where(lower, bj, bj + 1),
                       np.where(lower, bj + 1, bj)])  # fmt: skip
        weight = np.stack([np.where(lower, 1.0 - fi - fj, fi + fj - 1.0),
                           np.where(lower, fi, 1.0 - fi),
                           np.where(lower, fj, 1.0 - fj)])  # fmt: skip
        keys = self._vertex_key(vi, vj)
        sources = [self._source(keys[k], x, y) for k in range(3)]
        best_w = weight.max(axis=0)
        score = np.empty_like(weight)
        for k, (sx, sy, *_rest) in enumerate(sources):
            rank = _mix(self.grain_key[sy, sx] ^ keys[k]) >> np.uint64(11)
            score[k] = rank.astype(np.float64) / float(1 << 53) + TILE_COPY_BIAS * weight[k]
            # A copy whose vertex is too far behind the nearest never shows (as in the shader).
            score[k][TILE_COPY_BIAS * (best_w - weight[k]) >= 1.0] = -np.inf
        winner = np.argmax(score, axis=0)
        return tuple(np.choose(winner, [s[m] for s in sources]) for m in range(5))


def varied_maps(maps: MaterialMaps, layout: CopyLayout) -> MaterialMaps:
    """``maps`` (one tile) laid out as ``layout`` says: maps ``layout.tiles`` tiles across."""
    if layout.n != maps.size:
        raise ValueError(f"layout of {layout.n}² texels for maps of {maps.size}²")
    if layout.tiles == 1:
        return maps
    width = maps.size * layout.tiles
    base = np.empty((width, width, 3), np.float32)
    normal = np.empty((width, width, 3), np.float32)
    specular = np.empty((width, width), np.float32)
    occlusion = np.empty((width, width), np.float32)
    height = np.empty((width, width), np.float32)
    for start in range(0, width, BAND_ROWS):
        band = slice(start, min(start + BAND_ROWS, width))
        sx, sy, swap, mirror_x, mirror_y = layout.rows(band)
        base[band] = maps.base_color[sy, sx]
        specular[band] = maps.specular[sy, sx]
        occlusion[band] = maps.occlusion[sy, sx]
        height[band] = maps.height[sy, sx]
        # The copy's tangent-space normal in the image's axes: copy = A·image, so a vector's
        # image components are Aᵀ times its copy's (mirror, then swap back).
        n = maps.normal[sy, sx]
        nx = np.where(mirror_x, -n[..., 0], n[..., 0])
        ny = np.where(mirror_y, -n[..., 1], n[..., 1])
        normal[band, :, 0] = np.where(swap, ny, nx)
        normal[band, :, 1] = np.where(swap, nx, ny)
        normal[band, :, 2] = n[..., 2]
    roughness = np.broadcast_to(maps.roughness.flat[0], (width, width))
    return replace(maps, base_color=base, normal=normal, roughness=roughness, specular=specular,
                   occlusion=occlusion, height=height, tiles=layout.tiles)  # fmt: skip
