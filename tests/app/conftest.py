"""Fixtures of the editor tests: a real window under Xvfb on the bundled default preset."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

# The first full tile needs the EGL context and shader compile; later ones take milliseconds.
FIRST_PREVIEW_TIMEOUT_MS = 20_000
PREVIEW_TIMEOUT_MS = 10_000
REPO = Path(__file__).resolve().parents[2]


def run_python(*args: str, timeout: float = 120, env: dict | None = None):
    """``python ARGS`` in a child process on this checkout (``-m sand_editor …``, ``-c …``)."""
    return subprocess.run(
        [sys.executable, *args],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), **(env or {})},
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def show_and_wait_for_tile(editor, qtbot) -> None:
    """Show the window and wait for its first full-size tile."""
    editor.show()
    qtbot.waitExposed(editor)
    qtbot.waitUntil(
        lambda: not editor.regenerator.busy and editor.preview.textures is not None,
        timeout=FIRST_PREVIEW_TIMEOUT_MS,
    )


@pytest.fixture
def default_preset() -> Preset:
    return Preset.load(bundled_preset("paper-default"))


@pytest.fixture
def window(qtbot, default_preset):
    """The editor window, shown, with its first full-size preview generated."""
    from sand_editor.app import EditorWindow

    editor = EditorWindow(default_preset, source=bundled_preset("paper-default"))
    # Closing asks about unsaved changes; the test's edits are meant to be thrown away.
    qtbot.addWidget(editor, before_close_func=lambda w: w.model.undo_stack.setClean())
    show_and_wait_for_tile(editor, qtbot)
    assert editor.preview.textures.size == editor.preview.preview_size, "generation failed"
    return editor


@pytest.fixture
def model_signals(window):
    """Every (preset, changed_paths) the window's model emits from now on."""
    emitted = []
    window.model.changed.connect(lambda preset, paths: emitted.append((preset, paths)))
    return emitted
