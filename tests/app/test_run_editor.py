"""Starting the editor: no display, and a preset that does not load."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sand_editor.app import missing_display

REPO = Path(__file__).resolve().parents[2]
RUN = (
    "import sys; from sand_editor.app import run_editor; "
    "sys.exit(run_editor(sys.argv[1] if len(sys.argv) > 1 else None))"
)


def run_editor_process(env: dict[str, str], *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", RUN, *args],
        cwd=REPO,
        env={**env, "PYTHONPATH": str(REPO)},
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_without_a_display_it_explains_and_returns_2():
    env = {
        key: value
        for key, value in os.environ.items()
        if key not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")
    }
    result = run_editor_process(env)

    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("sand-editor: no display found")
    for command in ("sand-editor bake", "sand-editor render", "sand-editor bench"):
        assert command in lines[0]


@pytest.mark.qt
def test_a_preset_that_does_not_load_is_reported_and_returns_1(tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text("[1, 2]", encoding="utf-8")

    result = run_editor_process(dict(os.environ), str(broken))

    assert result.returncode == 1
    assert str(broken) in result.stderr and "top level is an array" in result.stderr


@pytest.mark.parametrize(
    ("environ", "platform", "missing"),
    [
        ({}, "linux", True),
        ({"DISPLAY": ":0"}, "linux", False),
        ({"WAYLAND_DISPLAY": "wayland-0"}, "linux", False),
        ({"QT_QPA_PLATFORM": "offscreen"}, "linux", False),
        ({"QT_QPA_PLATFORM": "vnc:size=800x600"}, "linux", False),
        ({"QT_QPA_PLATFORM": "wayland;xcb"}, "linux", True),
        ({"DISPLAY": ""}, "linux", True),
        ({}, "win32", False),
        ({}, "darwin", False),
    ],
)
def test_missing_display(environ, platform, missing):
    assert (missing_display(environ, platform) is not None) is missing
