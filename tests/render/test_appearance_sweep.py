"""Every shipped sand and random valid ones, at 0.3–30 m under a high and a low sun: no NaN or
inf, no frame with more than 1 % of its ground clipped white, and the close range's mean light
the far range's (sand_editor/bench/sweep.py measures; this holds it to its limits)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from sand_editor.bench.sweep import SHIPPED, Sweep, random_preset, sweep_presets
from sand_editor.preset import FIELDS, Preset
from sand_editor.resources import bundled_preset

RANDOM_PRESETS = int(os.environ.get("SAND_EDITOR_SWEEP_PRESETS", "6"))
# Close over far, as measured on this machine: shipped sands within 6.0 % (black-volcanic's
# glassy facets at 0.3 m, where the tile's Gaussian of slopes holds a little less light than
# the resolved grains), random ones within 16 % (a view that sees less than one tile of grains
# a metre across, whose colour is not the tile's average).
SHIPPED_LIMIT = 0.065
RANDOM_LIMIT = 0.2


@pytest.fixture(scope="module")
def sweep(gl_ctx):
    s = Sweep(gl_ctx)
    yield s
    s.release()


@pytest.fixture(scope="module")
def rows(sweep):
    return [row for preset in sweep_presets(RANDOM_PRESETS) for row in sweep.measure(preset)]


def test_no_nan_or_inf_anywhere(rows):
    assert all(row["finite"] for row in rows), [r for r in rows if not r["finite"]]


def test_at_most_one_percent_of_the_ground_is_clipped_white(rows):
    worst = max(rows, key=lambda row: row["clipped"])
    assert worst["clipped"] <= 0.01, worst


def test_close_and_far_hold_the_same_light(rows):
    for row in rows:
        limit = SHIPPED_LIMIT if row["preset"] in SHIPPED else RANDOM_LIMIT
        assert abs(row["close_over_far"] - 1.0) <= limit, row


def test_random_presets_reach_every_fields_extremes():
    rng = np.random.default_rng(2026)
    presets = [random_preset(rng) for _ in range(40)]
    for spec in FIELDS:
        if spec.kind not in ("float", "int") or spec.section == "":
            continue
        values = {p.get(spec.path) for p in presets}
        if spec.path in ("shading.uv_scale", "shading.sigmoid_a", "shading.sigmoid_b"):
            continue  # drawn within the range people use
        assert spec.minimum in values, spec.path
        if spec.path != "generation.period":
            assert spec.maximum in values, spec.path


def test_black_sand_is_black_and_glints(sweep):
    sweep.material.update(Preset.load(bundled_preset("black-volcanic")))
    sweep.renderer.set_material(sweep.material)
    size, sweep.frame_size = sweep.frame_size, (320, 180)  # the size the views use
    try:
        frame, _ = sweep.frame(0.3, "16:30")
    finally:
        sweep.frame_size = size
    ground = frame[frame.shape[0] // 2 :].astype(float) / 255.0
    linear = np.where(ground <= 0.04045, ground / 12.92, ((ground + 0.055) / 1.055) ** 2.4)
    luminance = linear @ np.array([0.2126, 0.7152, 0.0722])
    assert np.median(luminance) < 0.08, "black sand reads dark"
    # ... and its clear volcanic glass shows sparkles far brighter than the sand around them.
    assert (luminance > 10 * np.median(luminance)).mean() > 0.001
