"""Grain statistics against the reference method's sand, and the colour draw."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.generator.noise import grain_colour_index

pytestmark = pytest.mark.gl

DISTINCT = ("#ff0000", "#00ff00", "#0000ff", "#ffffff")


@pytest.mark.parametrize("seed", [270, 1, 2])
def test_paper_default_statistics(sand, seed):
    tex = sand.generate(sand.preset(seed=seed), 512, "gl")
    stats = tex.statistics(10)
    # Every layer adds grains in gaps: coverage of the layers and gaps sums to the tile.
    assert sum(stats["coverage_per_layer"]) + stats["gap_fraction"] == pytest.approx(1.0)
    assert all(c > 0 for c in stats["coverage_per_layer"])
    # Independent layers: each covers about the same share of what the layers above left open.
    left = 1.0 - np.concatenate([[0.0], np.cumsum(stats["coverage_per_layer"])[:-1]])
    share = np.array(stats["coverage_per_layer"]) / left
    assert share.max() - share.min() < 0.05


# Threshold and roundness across their useful range; the reference's sand is the yardstick.
LOOKS = [
    {},
    {"threshold": 0.15},
    {"threshold": 0.45},
    {"roundness": 0.6},
    {"roundness": 0.05},
]


@pytest.mark.parametrize(
    "generation", LOOKS, ids=lambda g: ",".join(map(str, g.items())) or "default"
)
def test_statistics_match_the_reference_sand(sand, gl_ctx, generation):
    """Coverage, gap fraction and grain count within 20 % of the reference port's sand."""
    from sand_editor.bench._reference_port import ReferenceParams, ReferencePort
    from sand_editor.bench.generator import look_statistics

    size = 256
    preset = sand.preset(**generation)
    port = ReferencePort(gl_ctx)
    try:
        port.render(ReferenceParams.from_preset(preset), size)
        out = port.read()
    finally:
        port.release()
    theirs = look_statistics(out["layer"], out["glint"].view(np.int32), 10)
    tex = sand.generate(preset, size, "gl")
    ours = look_statistics(tex.layer, tex.grain_id, 10)
    assert ours["coverage_top"] == pytest.approx(theirs["coverage_top"], rel=0.2)
    assert 1 - ours["gap_fraction"] == pytest.approx(1 - theirs["gap_fraction"], rel=0.2)
    assert ours["top_layer_grains"] == pytest.approx(theirs["top_layer_grains"], rel=0.2)
    assert ours["top_grain_area_px"] == pytest.approx(theirs["top_grain_area_px"], rel=0.2)


def test_single_weight_gives_one_colour_darkened_per_layer(sand, strict_numpy):
    preset = sand.preset(weights=(1.0, 0.0, 0.0, 0.0), colors=DISTINCT, layer_darkness=0.3)
    nc = sand.constants(preset)
    tex = sand.generate(preset, 128, "gl")
    owned = tex.layer >= 0
    expected = nc.layer_colors[tex.layer[owned], 0].astype(np.float32)
    np.testing.assert_array_equal(tex.albedo[owned], expected)
    assert len({tuple(c) for c in tex.albedo[tex.layer == 0]}) == 1
    # Darkened per layer: layer 1 is darker than layer 0.
    assert tex.albedo[tex.layer == 1].sum(axis=-1).max() < tex.albedo[tex.layer == 0].sum(-1).min()


@pytest.mark.parametrize("index", range(4))
def test_last_weight_only(sand, index, strict_numpy):
    weights = tuple(1.0 if i == index else 0.0 for i in range(4))
    preset = sand.preset(weights=weights, colors=DISTINCT)
    nc = sand.constants(preset)
    tex = sand.generate(preset, 64, "gl")
    top = tex.layer == 0
    np.testing.assert_array_equal(
        tex.albedo[top],
        np.broadcast_to(nc.layer_colors[0, index].astype(np.float32), tex.albedo[top].shape),
    )


def grain_colours(tex, nc) -> np.ndarray:
    """The palette index of each distinct top-layer grain, read from its albedo."""
    top = tex.layer == 0
    ids, first = np.unique(tex.grain_id[top], return_index=True)
    albedo = tex.albedo[top][first].astype(np.float64)
    palette = nc.layer_colors[0]
    distance = np.linalg.norm(albedo[:, None, :] - palette[None, :, :], axis=-1)
    assert distance.min(axis=1).max() < 1e-6, "a grain's albedo is not a layer-0 palette colour"
    index = distance.argmin(axis=1)
    np.testing.assert_array_equal(index, grain_colour_index(ids, nc.cumulative_weights))
    return index


@pytest.mark.parametrize(
    ("weights", "expected"),
    [((25.0, 25.0, 25.0, 25.0), (0.25,) * 4), ((22.0, 18.0, 56.0, 4.0), (0.22, 0.18, 0.56, 0.04))],
)
def test_colour_shares_per_grain(sand, weights, expected, strict_numpy):
    preset = sand.preset(weights=weights, colors=DISTINCT, period=72)
    nc = sand.constants(preset)
    index = grain_colours(sand.generate(preset, 512, "gl"), nc)
    assert index.size > 3000
    share = np.bincount(index, minlength=4) / index.size
    np.testing.assert_allclose(share, expected, atol=0.05)
