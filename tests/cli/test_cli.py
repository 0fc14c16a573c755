"""The sand-editor command line: help, dispatch and preset resolution."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sand_editor.cli import preset_path
from sand_editor.preset import PresetError
from sand_editor.resources import bundled_preset


def test_help_lists_the_commands():
    result = subprocess.run(
        [sys.executable, "-m", "sand_editor", "--help"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0
    for command in ("edit", "bake", "bench"):
        assert command in result.stdout


def test_preset_argument_resolution(tmp_path):
    assert preset_path(None) == bundled_preset("paper-default")
    assert preset_path("black-volcanic") == bundled_preset("black-volcanic")
    own = tmp_path / "mine.json"
    own.write_text("{}", encoding="utf-8")
    assert preset_path(str(own)) == own
    with pytest.raises(PresetError, match="no-such"):
        preset_path("no-such")
