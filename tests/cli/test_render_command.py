"""sand-editor render: a headless frame to a PNG, and clear errors for bad views."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.gl


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "sand_editor", *args], capture_output=True, text=True, timeout=300
    )


def test_render_writes_the_frame(tmp_path):
    out = tmp_path / "frames" / "noon.png"
    result = run_cli("render", "paper-default", "--out", str(out), "--size", "96x64",
                     "--distance", "0.5", "--time", "12:00", "--pitch", "30")  # fmt: skip
    assert result.returncode == 0, result.stderr
    image = np.asarray(Image.open(out))
    assert image.shape == (64, 96, 3)
    assert image.std() > 1.0, "a frame of sky and sand is not one flat colour"


def test_render_draws_a_still_with_more_samples(tmp_path):
    """--samples 2: the same view, its grains' outlines resolved within each pixel: close to the
    one-sample frame on average, not the same pixels."""
    frames = {}
    for samples in ("1", "2"):
        out = tmp_path / f"{samples}.png"
        result = run_cli("render", "paper-default", "--out", str(out), "--size", "96x64",
                         "--distance", "0.3", "--pitch", "30", "--samples", samples)  # fmt: skip
        assert result.returncode == 0, result.stderr
        frames[samples] = np.asarray(Image.open(out)).astype(np.float64)
    assert "2×2 samples" in result.stdout
    assert frames["2"].shape == frames["1"].shape
    assert abs(frames["2"].mean() - frames["1"].mean()) < 4.0
    assert np.abs(frames["2"] - frames["1"]).mean() > 1.0


def test_night_is_darker_than_noon(tmp_path):
    frames = {}
    for time in ("12:00", "00:30"):
        out = tmp_path / f"{time[:2]}.png"
        result = run_cli("render", "red-desert", "--out", str(out), "--size", "64x48",
                         "--distance", "2", "--time", time)  # fmt: skip
        assert result.returncode == 0, result.stderr
        frames[time] = np.asarray(Image.open(out)).mean()
    assert frames["00:30"] < frames["12:00"]


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--distance", "0"], "distance"),
        (["--distance", "nan"], "distance"),
        (["--pitch", "0.5"], "pitch"),
        (["--time", "25:00"], "HH:MM"),
        (["--size", "0x10"], "WIDTHxHEIGHT"),
        (["--mode", "wireframe"], "invalid choice"),
        (["--samples", "0"], "--samples"),
        (["--samples", "9"], "--samples"),
        (["--samples", "2.5"], "--samples"),
    ],
)
def test_bad_views_are_one_clear_line(tmp_path, args, fragment):
    out = tmp_path / "x.png"
    result = run_cli("render", "paper-default", "--out", str(out), "--size", "32x32", *args)
    assert result.returncode != 0
    assert fragment in result.stderr and "Traceback" not in result.stderr
    assert not out.exists()
