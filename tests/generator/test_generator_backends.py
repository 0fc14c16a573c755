"""The GL generator against the float64 reference: whole textures, sampled pixels of a 4096²
texture, and pixels placed exactly on cell borders, feature points and Voronoi borders."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.generator import reference
from sand_editor.generator.noise import MAX_LAYERS, PROFILE_OFFSET, PROFILE_SCALE

pytestmark = pytest.mark.gl


def angle_degrees(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = a.astype(np.float64)
    b = b.astype(np.float64)
    a /= np.linalg.norm(a, axis=-1, keepdims=True)
    b /= np.linalg.norm(b, axis=-1, keepdims=True)
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, (a * b).sum(axis=-1)))


def assert_backends_agree(gl, ref) -> None:
    agree = gl.layer == ref.layer
    assert (~agree).mean() < 0.005
    assert agree.mean() > 0.99999 or (~agree).sum() <= 1, f"{(~agree).sum()} layer mismatches"
    error = angle_degrees(gl.normal[agree], ref.normal[agree])
    assert error.mean() < 0.05
    assert np.percentile(error, 99.9) < 0.5
    assert (gl.grain_id[agree] == ref.grain_id[agree]).all()
    assert (gl.albedo[agree] == ref.albedo[agree]).all()
    assert (gl.glint[agree] == ref.glint[agree]).all()
    np.testing.assert_allclose(gl.height[agree], ref.height[agree], atol=2e-6)


@pytest.mark.parametrize("size", [128, 100, 64])
@pytest.mark.parametrize("seed", [270, 2**32 - 1])
def test_backends_agree(sand, size, seed, strict_numpy):
    preset = sand.preset(seed=seed)
    assert_backends_agree(
        sand.generate(preset, size, "gl"), sand.generate(preset, size, "reference")
    )


# Hard cases at a power-of-two size, where pixel centres and lattice distances are dyadic and
# exact in float32, so even exact distance ties break the same way in both backends.
@pytest.mark.parametrize(
    "generation",
    [
        {"threshold": 0.0},
        {"roundness": 1.0},
        {"layers": MAX_LAYERS},
        {"jitter": 0.0},
        {"jitter": 0.0, "threshold": 0.0},
        {"period": 1},
        {"period": 256},
        {"threshold": 0.0, "roundness": 0.0, "layers": MAX_LAYERS, "jitter": 0.0, "period": 1},
    ],
    ids=str,
)
def test_backends_agree_on_hard_cases(sand, generation, strict_numpy):
    preset = sand.preset(**generation)
    assert_backends_agree(sand.generate(preset, 64, "gl"), sand.generate(preset, 64, "reference"))


def test_lattice_ties_differ_only_on_the_tie_itself(sand, strict_numpy):
    # With jitter 0 the points form a lattice and grain borders are exact ties F1 == F2, where
    # the profile sits at its minimum PROFILE_OFFSET. At a size whose pixel centres are not dyadic
    # fractions, float32 and float64 round two tied distances differently and may pick different
    # nearest points: the profile there is non-differentiable, either side's normal is right.
    # Everything else must agree, and the tie pixels must still be valid.
    preset = sand.preset(threshold=0.0, roundness=0.0, jitter=0.0, period=1)
    gl, ref = sand.generate(preset, 96, "gl"), sand.generate(preset, 96, "reference")
    sand.check(gl, preset, 96)
    differ = (gl.grain_id != ref.grain_id) | (angle_degrees(gl.normal, ref.normal) > 0.5)
    assert differ.any(), "this lattice is meant to contain ties"
    on_tie = np.abs(ref.height.astype(np.float64) - PROFILE_OFFSET) < 1e-5
    assert on_tie[differ].all()
    assert differ.mean() < 0.05
    np.testing.assert_array_equal(gl.layer, ref.layer)


def test_4096_sampled_against_reference(sand, strict_numpy):
    n = 4096
    preset = sand.preset(layers=2, threshold=0.2)
    nc = sand.constants(preset)
    gl = sand.generate_fresh(preset, n, "gl")
    # Finiteness and ranges over the whole texture, cheaply (the full check is too slow here).
    assert gl.layer.dtype == np.int8 and gl.layer.shape == (n, n)
    assert gl.layer.min() == -1 and gl.layer.max() == 1
    assert np.isfinite(gl.normal).all() and np.isfinite(gl.height).all()
    assert (gl.normal[..., 2] > 0).all()
    assert (gl.glint[gl.layer != 0] == 0).all()
    rng = np.random.default_rng(4096)
    edge = np.array([0, 1, n // 2, n - 2, n - 1])
    xs = np.concatenate([rng.integers(0, n, 400), np.repeat(edge, edge.size)])
    ys = np.concatenate([rng.integers(0, n, 400), np.tile(edge, edge.size)])
    ref = reference.evaluate(nc, n, xs, ys)
    layer = gl.layer[ys, xs]
    assert (layer == ref["layer"]).all()
    assert (gl.grain_id[ys, xs] == ref["grain"]).all()
    assert angle_degrees(gl.normal[ys, xs], ref["normal"]).max() < 0.5
    np.testing.assert_allclose(gl.height[ys, xs], ref["height"], atol=2e-6)
    np.testing.assert_array_equal(gl.albedo[ys, xs], ref["albedo"].astype(np.float32))
    # The 4096² texture tiles: its last row/column continues into its first exactly as the
    # oracle, evaluated one pixel beyond the tile, says.
    beyond = reference.evaluate(nc, n, xs + n, ys - n)
    np.testing.assert_array_equal(beyond["layer"], ref["layer"])
    np.testing.assert_array_equal(beyond["normal"], ref["normal"])


def test_size_equal_to_period_exact_cell_centres(sand, strict_numpy):
    # size 64, period 32: every pixel centre sits at 0.25 or 0.75 of a cell, exactly on the
    # jitter-0 point anchors (0.25, 0.25) and (0.75, 0.75) in the plane, or on a Voronoi
    # border between them (0.25, 0.75), equidistant from four points.
    preset = sand.preset(jitter=0.0, period=32, threshold=0.0, roundness=0.0)
    gl, ref = sand.generate(preset, 64, "gl"), sand.generate(preset, 64, "reference")
    sand.check(gl, preset, 64)
    sand.check(ref, preset, 64)
    x = np.arange(64)
    on_point = (x[:, None] % 2) == (x[None, :] % 2)
    assert (gl.layer == ref.layer).all() and (gl.layer == 0).all()
    assert (gl.grain_id == ref.grain_id).all()
    np.testing.assert_allclose(gl.normal, ref.normal, atol=1e-6)
    np.testing.assert_allclose(gl.height, ref.height, atol=1e-6)
    # On a point: F1 = depth² = 0.25, F2 = 0.75 (the nearest other points).
    on_point_profile = PROFILE_OFFSET + PROFILE_SCALE * (np.sqrt(0.75) - 0.5)
    np.testing.assert_allclose(ref.height[on_point], on_point_profile, atol=1e-7)
    # On a border: four points tie at F = 0.5, so the profile is exactly its minimum.
    np.testing.assert_allclose(ref.height[~on_point], PROFILE_OFFSET, atol=1e-7)


def test_pixel_centres_on_cell_corners(sand, strict_numpy):
    # size 64, period 128: (2x + 1)·128 / 128 is an integer, so every pixel centre is on a cell
    # corner (frac 0): the shader's float floor() must still find the same cell as the integer
    # maths.
    for generation in ({"period": 128}, {"period": 128, "jitter": 0.0, "threshold": 0.0}):
        preset = sand.preset(**generation)
        assert_backends_agree(
            sand.generate(preset, 64, "gl"), sand.generate(preset, 64, "reference")
        )


def _tilt(tex, layer: int = 0) -> np.ndarray:
    """Tilt from the vertical, in degrees, of a layer's grain pixels."""
    normal = tex.normal[tex.layer == layer].astype(np.float64)
    return np.degrees(np.arccos(np.clip(normal[:, 2], -1.0, 1.0)))


def test_grains_are_ball_caps_whose_facets_face_the_sky(sand, strict_numpy):
    # The normal of a grain pixel is that of the cap of a ball of radius² grain_reach2 around its
    # nearest feature point: straight up over the point, tilting outwards to the rim, so that a
    # good share of every grain faces the sky (cone-shaped grains left a hole there).
    preset = sand.preset(roundness=0.28)
    tex = sand.generate(preset, 256, "reference")
    tilt = _tilt(tex)
    assert (tilt < 10.0).mean() > 0.05
    assert (tilt < 30.0).mean() > 0.3
    assert (tilt > 45.0).mean() > 0.05
    assert tilt.max() < 90.0


def test_roundness_makes_grains_rounder(sand, strict_numpy):
    # Higher roundness: smaller balls, so a grain's normals spread further from the vertical;
    # low roundness gives broad, flatter caps.
    medians = [
        np.median(_tilt(sand.generate(sand.preset(roundness=r), 256, "reference")))
        for r in (0.05, 0.28, 0.8)
    ]
    assert medians[0] < 15.0 < medians[1] < medians[2], medians
