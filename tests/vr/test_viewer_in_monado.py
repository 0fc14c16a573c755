"""``sand-editor vr`` against a real OpenXR runtime: Monado's simulated headset with simulated
controllers (tools/monado/run), driven over the stdio link as the editor drives it."""

from __future__ import annotations

import json
import math
import queue
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest

from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset
from sand_editor.vr.actions import BINDINGS
from sand_editor.vr.link import encode

pytestmark = [pytest.mark.openxr, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
OPENING = ["IDLE", "READY", "SYNCHRONIZED", "VISIBLE", "FOCUSED"]
CLOSING = ["VISIBLE", "SYNCHRONIZED", "STOPPING", "IDLE", "EXITING"]
FRAMES = 300


@pytest.fixture
def report_dir():
    """A folder the harness sees at the same path: inside the checkout (bind-mounted)."""
    scratch = REPO / ".scratch"
    scratch.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=scratch) as folder:
        yield Path(folder)


def _viewer(harness, controllers, *args):
    return subprocess.Popen(
        [str(harness), "--fail-on-validation", "--controllers", controllers, "--timeout", "500",
         "python", "-m", "sand_editor", "vr", *args],
        cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip


def _lines(proc) -> queue.Queue:
    lines: queue.Queue = queue.Queue()

    def read():
        for line in proc.stdout:
            lines.put(json.loads(line))
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    return lines


def _expect(lines, seen, predicate, timeout=300.0):
    end = time.monotonic() + timeout
    while True:
        message = lines.get(timeout=max(end - time.monotonic(), 0.1))
        assert message is not None, f"viewer ended early; seen {seen[-8:]}"
        seen.append(message)
        if predicate(message):
            return message


def test_300_frames_with_controllers_and_an_edit_regenerating(monado_harness, report_dir):
    report_path = report_dir / "report.json"
    proc = _viewer(
        monado_harness, "wmr", "--control", "stdio", "--frames", str(FRAMES),
        "--report", str(report_path),
    )  # fmt: skip
    seen: list[dict] = []
    try:
        lines = _lines(proc)
        ready = _expect(lines, seen, lambda m: m["type"] == "ready")
        assert ready["backend"] == "xr" and "Monado" in ready["runtime"]
        assert ready["views"] == [{"width": 320, "height": 240}] * 2
        edit = Preset.load(bundled_preset("red-desert")).replace(name="edited in the editor")
        proc.stdin.write(encode("preset", preset=edit.to_dict(), seq=7))
        proc.stdin.flush()
        applied = _expect(lines, seen, lambda m: m["type"] in ("applied", "error"))
        assert applied["type"] == "applied" and applied["seq"] == 7, applied
        # A teleport, a snap turn and the bench brought along, then a panel press: the jumps
        # the controllers make (the simulated ones cannot move), asked for over the link.
        proc.stdin.write(encode("move", to=[30.0, -40.0], turn_degrees=-30.0, bring_bench=True))
        proc.stdin.write(encode("press", button="later"))
        proc.stdin.flush()
        later = _expect(
            lines, seen, lambda m: m["type"] in ("time", "error") and m.get("hours") != 10.0
        )
        assert later["type"] == "time" and later["hours"] == pytest.approx(11.0), later
        bye = _expect(lines, seen, lambda m: m["type"] == "bye")
        assert bye["status"] == 0
        _, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, stderr[-4000:]
    states = [m["state"] for m in seen if m["type"] == "state"]
    assert states == OPENING + CLOSING

    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    assert report["states"] == OPENING + CLOSING
    assert report["frames_submitted"] == FRAMES
    # The first frame may come with should_render false; every other one is drawn.
    assert report["frames_rendered"] >= FRAMES - 5
    assert report["swapchain_format"] == "GL_SRGB8_ALPHA8"
    assert report["reference_space"] == "STAGE"
    for view in report["views"]:
        assert (view["width"], view["height"]) == (320, 240)
        assert set(view["fov"]) == {"angle_left", "angle_right", "angle_up", "angle_down"}
        assert view["fov"]["angle_left"] < 0 < view["fov"]["angle_right"]
    assert report["view_matrices_differ"] is True
    assert report["interaction_profiles"] == {
        "left": "/interaction_profiles/microsoft/motion_controller",
        "right": "/interaction_profiles/microsoft/motion_controller",
    }
    assert report["suggested_bindings"] == {profile: "accepted" for profile in BINDINGS}
    # Rebuilt only when the head moved to another level of detail, never between the eyes.
    assert 1 <= report["terrain_meshes_built"] <= report["head_level_of_detail_changes"]
    assert report["eye_ms"]["count"] == 2 * report["frames_rendered"]
    assert report["max_frame_gap_while_regenerating_ms"] > 0
    assert report["final"]["preset"] == "edited in the editor (editing)"
    assert report["final"]["hours"] == pytest.approx(11.0)
    moves = report["locomotion"]
    assert (moves["teleports"], moves["snap_turns"], moves["bench_moves"]) == (1, 1, 1)
    assert moves["yaw_deg"] == pytest.approx(-30.0)
    x, _, z = moves["head_in_world"]
    assert math.hypot(x - 30.0, z + 40.0) < 0.5  # the head is where it was sent
    # Depth for the compositor: a depth swapchain per eye, chained to each projection view.
    assert report["depth_submitted"] is True and report["depth_format"].startswith("GL_DEPTH")
    # Monado's null compositor refreshes at 20 Hz (XR_FB_display_refresh_rate says so): a frame
    # is paced to a whole number of its 50 ms periods. How many depends on the machine's load,
    # which a test does not assert.
    assert report["display_refresh_hz"] == pytest.approx(20.0)
    periods = report["display_periods_per_frame"]
    assert periods["count"] >= FRAMES - 2
    assert periods["median"] >= 1.0
    assert abs(periods["median"] - round(periods["median"])) < 0.1


def test_simple_controllers_bind_the_khr_profile(monado_harness, report_dir):
    report_path = report_dir / "report.json"
    proc = _viewer(monado_harness, "simple", "--frames", "20", "--report", str(report_path))
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr[-4000:]
    assert stdout == ""
    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    assert report["interaction_profiles"] == {
        "left": "/interaction_profiles/khr/simple_controller",
        "right": "/interaction_profiles/khr/simple_controller",
    }


def test_no_headset_controllers_means_no_hands_bound(monado_harness, report_dir):
    report_path = report_dir / "report.json"
    result = subprocess.run(
        [str(monado_harness), "--timeout", "300", "python", "-m", "sand_editor", "vr",
         "--frames", "10", "--report", str(report_path)],
        cwd=REPO, capture_output=True, text=True, timeout=320,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-4000:]
    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    assert report["interaction_profiles"] == {"left": None, "right": None}


def test_bench_vr_runtime_reports_the_session_and_the_edit(monado_harness, tmp_path):
    out = tmp_path / "vr-runtime.json"
    result = subprocess.run(
        [sys.executable, "-m", "sand_editor", "bench", "vr-runtime", "--quick", "--json", str(out)],
        cwd=REPO, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    report = json.loads(out.read_text())
    assert report["frames_submitted"] == 100 and report["errors"] == []
    assert report["edit_applied"]["type"] == "applied"
    assert "| edit received → on screen (`applied`) |" in result.stdout
