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


@pytest.fixture
def headless(gl_ctx):
    """A frame loop on the headless backend at 64×48 per eye, with small grain textures."""
    from sand_editor.preset import Preset
    from sand_editor.resources import bundled_preset
    from sand_editor.vr.glwindow import HeadlessContexts
    from sand_editor.vr.headless import HeadlessBackend
    from sand_editor.vr.link import NullLink
    from sand_editor.vr.loop import FrameLoop, ViewerOptions

    windows = HeadlessContexts()
    backend = HeadlessBackend(windows, (64, 48))
    preset = Preset.load(bundled_preset("paper-default"))
    options = ViewerOptions(preset, "paper-default", frames=4, texture_size=256)
    loop = FrameLoop(backend, windows, NullLink(), options)
    try:
        yield backend, loop
    finally:
        loop.close()
        backend.close()


@pytest.mark.gl
def test_the_headless_backend_draws_both_eyes_through_the_frame_loop(headless, gl_ctx):
    from sand_editor.gl import standalone_context

    backend, loop = headless
    loop.start()
    loop.run()
    assert backend.frames_ended == backend.frames_rendered == 4
    assert loop.stats.frames_rendered == 4
    assert len(loop.stats.eye_ms) == 8 and all(ms > 0 for ms in loop.stats.eye_ms)
    assert loop.stats.states[0] == "IDLE" and loop.stats.states[-1] == "EXITING"
    left, right = backend.eye_image(0), backend.eye_image(1)
    assert left.shape == right.shape == (48, 64, 3)
    for image in (left, right):
        assert image.mean() > 20  # sand and sky, not black
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 50
    assert np.abs(left.astype(int) - right.astype(int)).mean() > 0.5  # two points of view
    assert loop.report()["view_matrices_differ"]
    # The test suite's own headless context comes back afterwards.
    assert standalone_context() is gl_ctx


@pytest.mark.gl
def test_stop_after_ends_the_session_through_its_closing_states(headless):
    backend, loop = headless
    loop.options.frames = None
    backend.stop_after = lambda ended: ended >= 2
    loop.start()
    loop.run()
    assert backend.frames_ended == 2
    assert loop.stats.states[-4:] == ["SYNCHRONIZED", "STOPPING", "IDLE", "EXITING"]


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
    assert 0 < generator["median_s"] <= generator["median_with_readback_s"]
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
