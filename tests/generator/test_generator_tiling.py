"""The texture is one tile of a periodic pattern: exactly in the oracle, seamlessly in GL."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.generator import reference
from sand_editor.generator.noise import pixel_cells

CASES = [(64, 36), (100, 36), (96, 7), (64, 1), (64, 256), (128, 128)]


@pytest.mark.parametrize(("size", "period"), CASES)
def test_pixel_cells_wrap_exactly(size, period):
    x = np.arange(-size, 2 * size)
    cell, frac = pixel_cells(x, size, period)
    base_cell, base_frac = pixel_cells(x % size, size, period)
    np.testing.assert_array_equal(frac, base_frac)
    np.testing.assert_array_equal(cell - base_cell, (x // size) * period)
    assert (0 <= frac).all() and (frac < 1).all()


@pytest.mark.parametrize(("size", "period"), CASES)
def test_oracle_is_periodic(sand, size, period, strict_numpy):
    nc = sand.constants(sand.preset(period=period, threshold=0.15, layers=4))
    rng = np.random.default_rng(size * 1000 + period)
    edge = np.array([0, 1, size - 2, size - 1])
    xs = np.concatenate([rng.integers(0, size, 300), np.repeat(edge, edge.size)])
    ys = np.concatenate([rng.integers(0, size, 300), np.tile(edge, edge.size)])
    base = reference.evaluate(nc, size, xs, ys)
    # One tile further along x, y and both, and one tile back (negative pixel indices).
    for dx, dy in [(size, 0), (0, size), (size, size), (-size, 0), (0, -size), (-size, 3 * size)]:
        moved = reference.evaluate(nc, size, xs + dx, ys + dy)
        for key in ("layer", "grain", "normal", "height", "albedo", "glint"):
            np.testing.assert_array_equal(moved[key], base[key], err_msg=f"{key} at {dx},{dy}")


def test_oracle_neighbours_across_the_edge(sand, strict_numpy):
    # Columns −1 and N are columns N−1 and 0: the neighbourhood of the seam is the same texture.
    size = 100
    nc = sand.constants(sand.preset())
    ys = np.arange(size)
    for outside, inside in [(-1, size - 1), (size, 0)]:
        a = reference.evaluate(nc, size, np.full(size, outside), ys)
        b = reference.evaluate(nc, size, np.full(size, inside), ys)
        np.testing.assert_array_equal(a["normal"], b["normal"])
        np.testing.assert_array_equal(a["layer"], b["layer"])


def mean_jump(height: np.ndarray, axis: int) -> tuple[float, float]:
    """Mean absolute height difference across the wrap edge, and between interior neighbours."""
    seam = np.abs(np.take(height, 0, axis) - np.take(height, -1, axis)).mean()
    interior = np.abs(np.diff(height, axis=axis)).mean()
    return float(seam), float(interior)


@pytest.mark.gl
@pytest.mark.parametrize(("size", "period"), [(256, 36), (200, 36), (128, 7)])
def test_gl_tiles_without_seam(sand, size, period):
    preset = sand.preset(period=period)
    tex = sand.generate(preset, size, "gl")
    tiled = np.tile(tex.height.astype(np.float64), (2, 2))
    for axis in (0, 1):
        seam, interior = mean_jump(tex.height.astype(np.float64), axis)
        assert interior / 1.5 < seam < interior * 1.5, (axis, seam, interior)
        # The 2×2 tiling's middle seam is the same jump, and looks like its interior.
        middle = np.abs(np.diff(tiled, axis=axis)).take(size - 1, axis).mean()
        assert middle == pytest.approx(seam)
    # Grains continue across the edge: the same grain owns both sides far more often than not.
    owned = (tex.layer[:, 0] >= 0) & (tex.layer[:, -1] >= 0)
    same = (
        owned & (tex.grain_id[:, 0] == tex.grain_id[:, -1]) & (tex.layer[:, 0] == tex.layer[:, -1])
    )
    inner = (tex.layer[:, 1:] >= 0) & (tex.layer[:, :-1] >= 0)
    inner_same = inner & (tex.grain_id[:, 1:] == tex.grain_id[:, :-1])
    assert abs(same.sum() / owned.sum() - inner_same.sum() / inner.sum()) < 0.1


@pytest.mark.gl
def test_gl_edge_matches_oracle_beyond_the_tile(sand, strict_numpy):
    size = 100
    preset = sand.preset()
    tex = sand.generate(preset, size, "gl")
    ys = np.arange(size)
    beyond = reference.evaluate(sand.constants(preset), size, np.full(size, size), ys)
    np.testing.assert_array_equal(tex.layer[:, 0], beyond["layer"])
    np.testing.assert_array_equal(tex.grain_id[:, 0], beyond["grain"])
    np.testing.assert_allclose(tex.normal[:, 0], beyond["normal"], atol=2e-5)
