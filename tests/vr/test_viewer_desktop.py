"""``sand-editor vr`` on this machine: the desktop preview under Xvfb, its report, the stdio
link the editor drives it through, and the exit statuses when no OpenXR runtime is there."""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset
from sand_editor.vr.link import (
    EXIT_BAD_INPUT,
    EXIT_GRAPHICS,
    EXIT_INTERRUPTED,
    EXIT_NO_RUNTIME,
    encode,
)

REPO = Path(__file__).resolve().parents[2]
OPENING = ["IDLE", "READY", "SYNCHRONIZED", "VISIBLE", "FOCUSED"]
CLOSING = ["VISIBLE", "SYNCHRONIZED", "STOPPING", "IDLE", "EXITING"]

needs_display = pytest.mark.skipif(not os.environ.get("DISPLAY"), reason="needs an X display")


def _env(**extra) -> dict:
    env = dict(os.environ, PYTHONPATH=str(REPO), **extra)
    return env


def _vr(*args, timeout=240, **env) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "sand_editor", "vr", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=_env(**env),
    )


@needs_display
def test_desktop_report_and_stereo_screenshot(tmp_path):
    report_path, shot = tmp_path / "report.json", tmp_path / "shot.png"
    result = _vr(
        "red-desert", "--desktop", "--frames", "6", "--render-scale", "0.25", "--time", "16:30",
        "--report", str(report_path), "--screenshot", str(shot),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout == "", "the viewer writes nothing but link messages on stdout"
    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    assert report["backend"] == "desktop"
    assert report["frames_submitted"] == 6
    assert report["states"] == OPENING + CLOSING
    assert len(report["views"]) == 2
    for view in report["views"]:
        assert view["width"] == 120 and view["height"] == 90
        fov = view["fov"]
        assert (
            fov["angle_left"] < 0 < fov["angle_right"] and fov["angle_down"] < 0 < fov["angle_up"]
        )
    assert report["view_matrices_differ"] is True
    assert report["terrain_meshes_built"] <= report["head_level_of_detail_changes"] == 1
    assert report["eye_ms"]["count"] == 12 and report["eye_ms"]["median"] > 0
    assert report["frame_overhead_ms"]["count"] == 6
    assert report["max_frame_gap_ms"] > 0
    assert report["final"]["preset"] == "red-desert"
    assert report["final"]["hours"] == pytest.approx(16.5)

    image = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    assert image.shape[0] == 90 and image.shape[1] == 2 * 120 + 4
    left, right = image[:, :120], image[:, -120:]
    assert np.abs(left - right).mean() > 0.5, "the two eyes must see from different places"
    assert np.abs(left - right).mean() < 40, "but the same scene"
    assert image[:20].mean() > 40, "the sky at 16:30 is lit"


def _eyes_of(shot: Path, eye: tuple[int, int]) -> list[np.ndarray]:
    """The two eye images of a screenshot, checked to be a whole PNG of both eyes side by side
    with the black line between them."""
    with Image.open(shot) as png:
        assert png.format == "PNG"
        png.verify()  # the whole file: a half-written one fails here
    image = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    width, height = eye
    assert image.shape == (height, 2 * width + 4, 3)
    assert image[:, width : width + 4].max() == 0, "the line between the eyes"
    return [image[:, :width], image[:, -width:]]


@needs_display
@pytest.mark.parametrize("control", ["none", "stdio"])
def test_a_screenshot_after_300_frames_leaves_no_gl_error_behind(tmp_path, control):
    """The eyes are read back from the viewer's own framebuffer. Reading the window's
    (moderngl's ``ctx.screen``) left GL_INVALID_OPERATION pending, which the next PyOpenGL call
    raised: the GL object count after frame 50 ended the viewer with status 5."""
    report_path, shot = tmp_path / "report.json", tmp_path / "shot.png"
    args = ("--desktop", "--render-scale", "0.1", "--frames", "300", "--screenshot", str(shot),
            "--report", str(report_path))  # fmt: skip
    if control == "none":
        result = _vr(*args)
        assert result.returncode == 0, result.stderr[-3000:]
    else:
        viewer = _Viewer(*args)
        try:
            viewer.expect(lambda m: m["type"] == "ready")
            viewer.send("time", hours=16.5, day_speed=0.0, playing=False)
            viewer.send("mode", mode="lambert")
            assert viewer.expect(lambda m: m["type"] == "bye")["status"] == 0, viewer.seen
            assert viewer.finish() == 0
        finally:
            viewer.finish(timeout=5)
        assert not [m for m in viewer.seen if m["type"] == "error"], viewer.seen
    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    assert report["frames_submitted"] == 300
    # Both counts were taken: at frame 50 and after the screenshot at the last frame.
    assert set(report["resources"]) == {"after_warm_up", "end"}
    for eye in _eyes_of(shot, (48, 36)):
        assert eye.mean() > 20, "an eye lit by the day, not a black image"
        assert eye.std() > 3, "an eye that shows a scene, not one colour"


def test_no_runtime_gives_exit_status_3_and_says_what_to_install(tmp_path):
    report_path = tmp_path / "report.json"
    result = _vr(
        "--frames", "1", "--report", str(report_path),
        XR_RUNTIME_JSON=str(tmp_path / "no-such-runtime.json"),
    )  # fmt: skip
    assert result.returncode == EXIT_NO_RUNTIME, result.stderr
    assert "OpenXR runtime" in result.stderr
    assert "SteamVR, Monado or WiVRn" in result.stderr
    assert "--desktop" in result.stderr
    report = json.loads(report_path.read_text())
    assert report["errors"] and "OpenXR runtime" in report["errors"][0]


def test_no_runtime_over_the_link_ends_with_an_error_and_bye(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "sand_editor", "vr", "--control", "stdio"],
        cwd=REPO,
        input="",
        capture_output=True,
        text=True,
        timeout=120,
        env=_env(XR_RUNTIME_JSON=str(tmp_path / "none.json")),
    )
    assert result.returncode == EXIT_NO_RUNTIME
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert lines[0]["type"] == "error" and "OpenXR runtime" in lines[0]["message"]
    assert lines[-1] == {"type": "bye", "status": EXIT_NO_RUNTIME}


@pytest.mark.parametrize(
    "args,needle",
    [
        (["no-such-preset"], "no-such-preset"),
        (["--render-scale", "0"], "--render-scale"),
        (["--time", "25:00"], "time of day"),
        (["--day-speed", "100"], "--day-speed"),
        (["--frames", "0"], "--frames"),
    ],
)
def test_bad_arguments_exit_with_status_1_or_2_naming_them(args, needle):
    result = _vr("--desktop", *args, timeout=60)
    assert result.returncode in (EXIT_BAD_INPUT, 2)  # 2: argparse's own usage errors
    assert needle in result.stderr


def test_no_display_gives_exit_status_5_and_says_so():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run(
        [sys.executable, "-m", "sand_editor", "vr", "--desktop", "--frames", "1"],
        cwd=REPO, capture_output=True, text=True, timeout=120,
        env={**env, "PYTHONPATH": str(REPO)},
    )  # fmt: skip
    assert result.returncode == EXIT_GRAPHICS, result.stderr
    assert "no X display" in result.stderr


class _Viewer:
    """The viewer as the editor runs it: JSON lines in, JSON lines out."""

    def __init__(self, *args, **env):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "sand_editor", "vr", "--control", "stdio", *args],
            cwd=REPO,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(**env),
        )
        self.lines: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.seen: list[dict] = []

    def _read(self):
        for line in self.proc.stdout:
            self.lines.put(json.loads(line))
        self.lines.put(None)

    def send(self, type, **fields):  # noqa: A002
        self.proc.stdin.write(encode(type, **fields))
        self.proc.stdin.flush()

    def send_raw(self, data: bytes) -> None:
        """Bytes as they are, whatever they hold."""
        self.proc.stdin.flush()
        self.proc.stdin.buffer.write(data)
        self.proc.stdin.buffer.flush()

    def expect(self, predicate, timeout=120.0) -> dict:
        end = time.monotonic() + timeout
        while True:
            remaining = end - time.monotonic()
            assert remaining > 0, f"timed out; seen {self.seen[-10:]}"
            message = self.lines.get(timeout=remaining)
            assert message is not None, f"viewer ended early: {self.proc.stderr.read()[-3000:]}"
            self.seen.append(message)
            if predicate(message):
                return message

    def finish(self, timeout=60.0) -> int | None:
        """The exit status; a viewer still running after ``timeout`` is killed (None)."""
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            return None


def _edited(name: str, **changes) -> dict:
    preset = Preset.load(bundled_preset("paper-default")).replace(name=name, **changes)
    return preset.to_dict()


@needs_display
def test_stdio_link_applies_an_edit_and_a_time_change_and_quits_cleanly(tmp_path):
    report_path = tmp_path / "report.json"
    viewer = _Viewer("--desktop", "--render-scale", "0.2", "--report", str(report_path))
    try:
        ready = viewer.expect(lambda m: m["type"] == "ready")
        assert ready["backend"] == "desktop" and len(ready["views"]) == 2
        states = [m["state"] for m in viewer.seen if m["type"] == "state"]
        assert states == OPENING
        first_time = viewer.expect(lambda m: m["type"] == "time")
        assert first_time["hours"] == pytest.approx(10.0) and first_time["playing"] is False

        edit = _edited("my sand", **{"generation.threshold": 0.3})
        viewer.send("preset", preset=edit, seq=1)
        viewer.send("time", hours=16.5, day_speed=0.0, playing=False)
        viewer.send("mode", mode="lambert")
        applied = viewer.expect(lambda m: m["type"] in ("applied", "error"))
        assert applied["type"] == "applied" and applied["seq"] == 1, applied
        assert applied["ms"] > 0

        bad = {**edit, "generation": {**edit["generation"], "threshold": "lots"}}
        viewer.send("preset", preset=bad, seq=2)
        error = viewer.expect(lambda m: m["type"] == "error")
        assert "threshold" in error["message"]
        viewer.send("wave", hand="right")
        assert "wave" in viewer.expect(lambda m: m["type"] == "error")["message"]
        viewer.send("time", hours=30)
        assert "hours" in viewer.expect(lambda m: m["type"] == "error")["message"]

        viewer.send("quit")
        bye = viewer.expect(lambda m: m["type"] == "bye")
        assert bye["status"] == 0
        assert viewer.finish() == 0
    finally:
        viewer.finish(timeout=5)
    later_states = [m["state"] for m in viewer.seen if m["type"] == "state"]
    assert later_states[-len(CLOSING) :] == CLOSING
    report = json.loads(report_path.read_text())
    assert report["final"]["hours"] == pytest.approx(16.5)
    assert report["final"]["mode"] == "lambert"
    assert report["final"]["preset"] == "my sand (editing)"
    assert len(report["errors"]) == 3  # the bad preset, the unknown type, the bad time


@needs_display
def test_eof_on_stdin_ends_the_viewer_cleanly():
    viewer = _Viewer("--desktop", "--render-scale", "0.1")
    try:
        viewer.expect(lambda m: m["type"] == "ready")
        viewer.proc.stdin.close()
        assert viewer.expect(lambda m: m["type"] == "bye")["status"] == 0
        assert viewer.finish() == 0
    finally:
        viewer.finish(timeout=5)


@needs_display
def test_sigterm_ends_the_session_cleanly_with_status_130(tmp_path):
    report_path = tmp_path / "report.json"
    viewer = _Viewer("--desktop", "--render-scale", "0.1", "--report", str(report_path))
    try:
        viewer.expect(lambda m: m["type"] == "ready")
        viewer.proc.send_signal(signal.SIGTERM)
        assert viewer.expect(lambda m: m["type"] == "bye")["status"] == EXIT_INTERRUPTED
        assert viewer.finish() == EXIT_INTERRUPTED
    finally:
        viewer.finish(timeout=5)
    report = json.loads(report_path.read_text())
    assert report["states"][-len(CLOSING) :] == CLOSING
    assert report["errors"] == ["interrupted"]


@needs_display
@pytest.mark.slow
def test_soak_2000_frames_keep_gl_objects_and_memory_flat(tmp_path):
    """Long sessions with the day running and new grains arriving hold no more GL objects or
    memory at the end than after warming up."""
    report_path = tmp_path / "report.json"
    viewer = _Viewer(
        "--desktop", "--render-scale", "0.05", "--frames", "2000", "--day-speed", "24",
        "--report", str(report_path),
    )  # fmt: skip
    try:
        viewer.expect(lambda m: m["type"] == "ready")
        for seq in range(1, 6):
            threshold = 0.3 + 0.05 * seq
            viewer.send(
                "preset",
                preset=_edited(f"soak {seq}", **{"generation.threshold": threshold}),
                seq=seq,
            )
            viewer.expect(lambda m, s=seq: m["type"] == "applied" and m["seq"] == s)
        assert viewer.expect(lambda m: m["type"] == "bye", timeout=600)["status"] == 0
        assert viewer.finish() == 0
    finally:
        viewer.finish(timeout=5)
    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    assert report["frames_submitted"] == 2000
    resources = report["resources"]
    warm, end = resources["after_warm_up"], resources["end"]
    assert sum(warm["gl_objects"].values()) > 10
    assert end["gl_objects"] == warm["gl_objects"]
    assert end["resident_mb"] - warm["resident_mb"] < 40


@needs_display
def test_the_editors_tile_in_shared_memory_is_shown_instead_of_made_again(tmp_path, gl_ctx):
    from sand_editor.generator import generate
    from sand_editor.generator.shared import SEGMENT_FOLDER, SharedTile, read_shared

    report_path = tmp_path / "report.json"
    size = 256
    args = ("--desktop", "--render-scale", "0.1", "--texture-size", str(size))
    viewer = _Viewer(*args, "--report", str(report_path))
    edit = Preset.from_dict(_edited("shared", **{"generation.seed": 4242}))
    tile = SharedTile(generate(edit, size, ctx=gl_ctx))
    larger = SharedTile(generate(edit, 2 * size, ctx=gl_ctx))
    fifo = Path(SEGMENT_FOLDER) / f"sand_test_fifo_{os.getpid()}"
    os.mkfifo(fifo, 0o600)  # opening it to read would wait for a writer: the grains with it
    try:
        viewer.expect(lambda m: m["type"] == "ready")
        grains = {"shm": tile.name, "size": size}
        viewer.send("preset", preset=edit.to_dict(), seq=1, grains=grains)
        applied = viewer.expect(lambda m: m["type"] in ("applied", "error"))
        assert applied["type"] == "applied" and applied["grains"] == "editor", viewer.seen

        # A segment that is gone, of another size or no file at all is said once; the viewer
        # makes the grains.
        cases = [
            ("psm_gone", size, "no shared tile"),
            (larger.name, 2 * size, "its tile is 512²"),
            (fifo.name, size, "is a FIFO, not a segment"),
        ]
        for seq, (name, tile_size, reason) in enumerate(cases, start=2):
            viewer.seen.clear()
            other = edit.replace(**{"generation.seed": 4242 + seq})
            grains = {"shm": name, "size": tile_size}
            viewer.send("preset", preset=other.to_dict(), seq=seq, grains=grains)
            applied = viewer.expect(lambda m, seq=seq: m.get("seq") == seq)
            assert applied["grains"] == "viewer"
            errors = [m["message"] for m in viewer.seen if m["type"] == "error"]
            assert len(errors) == 1 and reason in errors[0], viewer.seen

        # A shading edit needs no grains.
        shading = other.replace(**{"shading.facet_roughness": 0.3})
        viewer.send("preset", preset=shading.to_dict(), seq=9)
        assert viewer.expect(lambda m: m.get("seq") == 9)["grains"] == "kept"
        viewer.send("quit")
        assert viewer.expect(lambda m: m["type"] == "bye")["status"] == 0
        assert viewer.finish() == 0
        # The viewer read the segment and let it be: the editor's to unlink.
        assert read_shared(tile.name, size, edit.generation).size == size
        assert fifo.exists(), "the viewer removed a FIFO it was pointed at"
    finally:
        viewer.finish(timeout=5)
        tile.close()
        larger.close()
        fifo.unlink(missing_ok=True)
    report = json.loads(report_path.read_text())
    # After the first sand (made before the first frame), each edit once.
    assert report["materials_shown_by_grain_source"] == {"viewer": 3, "editor": 1, "kept": 1}
