"""The GPU benchmark: the headless backend drives the viewer's real frame loop with no display,
and the command runs without Qt or OpenXR and writes what it measured."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _bench_run import run_bench

from sand_editor.bench.gpu import FrameBudget, _FrameCounter, fixed_frames

REPO = Path(__file__).resolve().parents[2]
EDGE = ("PySide6", "xr")


# The headless backend runs in a process of its own (the command's, below): its EGL contexts
# must not share a process with the Qt tests' GLX ones and the suite's own context.


def test_the_frame_counter_warms_up_then_counts_the_timed_frames():
    counter = _FrameCounter(fixed_frames(3))
    assert [counter(ended) for ended in range(1, 6)] == [False, False, False, True, True]
    assert counter.warm_up == 1
    boxed = _FrameCounter(FrameBudget(2, 0.0, 1, 100, 1e9))  # a time box that never ends
    assert not any(boxed(ended) for ended in range(1, 100))
    assert boxed(102)  # ... but at most max_frames timed frames


@pytest.mark.gl
def test_the_command_measures_every_part_without_qt_or_openxr(tmp_path):
    json_path = tmp_path / "gpu.json"
    command = [sys.executable, "-m", "sand_editor.bench.gpu", "--quick", "--eye-scale", "0.03",
               "--frames", "2", "--sizes", "64", "--json", str(json_path)]  # fmt: skip
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "| 62×66 | 2 |" in result.stdout
    data = json.loads(json_path.read_text())
    assert data["modules_qt_or_xr"] == []
    for key in ("gl_renderer", "gl_version", "cpu_model", "cpu_count"):
        assert data["machine"][key]
    assert list(data["stereo"]) == ["62x66", "55x58"]
    for row in data["stereo"].values():
        assert row["frames_timed"] == 2 and row["frames_warm_up"] == 1
        for part in ("eyes_ms", "own_work_ms", "total_ms"):
            assert 0 < row[part]["median"] <= row[part]["p90"]
        assert row["total_ms"]["median"] >= row["eyes_ms"]["median"]
        assert min(row["eye_mean_level"]) > 20 and row["eyes_differ"]
    generator = data["generator"]["64"]
    assert generator["median_s"] > 0 and generator["median_with_readback_s"] > 0
    costs = data["render_costs"]
    assert set(costs["per_distance_ms"]) == {"0.1", "0.3", "1.0", "3.0", "10.0", "30.0"}
    for row in costs["per_distance_ms"].values():
        assert set(row) == {"ours", "expected", "reference", "none"}
        assert all(np.isfinite(ms) and ms > 0 for ms in row.values())
    assert costs["material_ms_per_megapixel"]["full"] > 0


def test_the_bench_command_path_imports_no_qt_or_openxr():
    """``sand-editor bench gpu`` goes through the CLI: neither it nor the bench pulls them in."""
    code = (
        "import sys\n"
        "from sand_editor import cli\n"
        "args = cli._parser().parse_args(['bench', 'gpu', '--quick'])\n"
        "import sand_editor.bench.gpu\n"
        f"print(sorted(m for m in sys.modules if m.split('.')[0] in {EDGE!r}))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.strip() == "[]"


def test_the_gpu_bench_draws_no_plot():
    from sand_editor.cli import main

    assert main(["bench", "gpu", "--plot", "x.png"]) == 1


@pytest.mark.gl
@pytest.mark.slow
def test_bench_gpu_quick_runs_as_the_command(tmp_path):
    json_path = tmp_path / "gpu.json"
    result = run_bench("gpu", "--sizes", "64", "--json", str(json_path), timeout=600)
    assert "| 1032×1104 |" in result.stdout and "| 916×960 |" in result.stdout
    data = json.loads(json_path.read_text())
    assert data["quick"] and data["modules_qt_or_xr"] == []
    assert all(row["frames_timed"] >= 3 for row in data["stereo"].values())
