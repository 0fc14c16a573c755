"""The depth bench: its supersampling averages in linear light, FLIP (NVIDIA's metric, not ours)
sees what it should, and the command writes its table and JSON with each feature's effect."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _bench_run import run_bench

from sand_editor.bench.depth import flip_error, supersampled


def test_supersampling_averages_light_not_encoded_values():
    checker = np.zeros((4, 4, 3), dtype=np.uint8)
    checker[::2, ::2] = checker[1::2, 1::2] = 255
    half = supersampled(checker, 2)
    assert half.shape == (2, 2, 3)
    # Half black, half white is half the light: sRGB 0.735, not 0.5.
    assert np.allclose(half, 0.7353569, atol=1e-4)
    flat = np.full((16, 8, 3), 90, dtype=np.uint8)
    assert np.allclose(supersampled(flat, 8), 90 / 255.0, atol=1e-6)


def test_flip_is_zero_for_the_same_frame_and_grows_with_the_difference():
    rng = np.random.default_rng(3)
    frame = rng.uniform(0.2, 0.8, size=(64, 96, 3))
    assert flip_error(frame, frame) == pytest.approx(0.0, abs=1e-6)
    slightly = np.clip(frame + 0.02, 0, 1)
    very = np.clip(frame[:, ::-1] * 0.5, 0, 1)
    assert 0.0 < flip_error(frame, slightly) < flip_error(frame, very) <= 1.0


@pytest.mark.gl
@pytest.mark.slow
def test_depth_bench_writes_its_table_and_each_features_effect(tmp_path):
    json_path = tmp_path / "depth.json"
    result = run_bench("depth", "--json", str(json_path), timeout=900)
    assert "| 10 m |" in result.stdout
    table = [line for line in result.stdout.splitlines() if line.startswith("|")]
    assert len({line.count("|") for line in table}) == 1, "every row as wide as the header"
    rows = {row["distance_m"]: row for row in json.loads(json_path.read_text())["rows"]}
    assert set(rows) == {0.05, 10.0}
    for row in rows.values():
        for setting in ("all", "no_relief", "no_sharp_ripples", "no_anisotropic", "no_shadows"):
            assert 0.0 <= row[setting]["flip"] <= 1.0 and row[setting]["ms"] > 0
        # More samples per pixel bring the same renderer nearer its 8×8 truth.
        floors = row["supersampled"]
        assert floors["4"] < floors["2"] < row["no_anisotropic"]["flip"], row
    # The supersampled truth has the grains' relief: the flat frame is the farther from it ...
    assert rows[0.05]["no_relief"]["flip"] > 1.5 * rows[0.05]["all"]["flip"]
    # ... the grains read in taps along the grazing footprint stay as sharp as the truth's
    # (one level for the footprint blurs them sideways) ...
    assert rows[0.05]["all"]["flip"] < 0.8 * rows[0.05]["no_anisotropic"]["flip"]
    # ... and ripples filtered along the footprint keep the truth's contrast better.
    assert rows[10.0]["all"]["flip"] < rows[10.0]["no_sharp_ripples"]["flip"]
    # The truth's samples gathered before the tone curve part from it up close, where sparkles
    # far brighter than white lie within a pixel, more than where the sand is even.
    assert 0.0 < rows[10.0]["gathered"] < rows[0.05]["gathered"] < 1.0, rows
    # A quarter-pixel pan changes our frames at most 1.5 times as much as it changes the truth.
    for row in rows.values():
        flicker = row["flicker"]
        assert flicker["truth"] > 0.0, "the pan moved the truth"
        assert 0.0 < flicker["ours"] and flicker["ratio"] <= 1.5, flicker
