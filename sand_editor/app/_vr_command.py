"""The command line that starts the VR viewer from the editor."""

from __future__ import annotations

import os
import shlex
import sys
from pathlib import Path

__all__ = ["PYTHON_VARIABLE", "WRAPPER_VARIABLE", "viewer_command"]

WRAPPER_VARIABLE = "SAND_EDITOR_VR_WRAPPER"
# The interpreter that runs the viewer; a wrapper that changes root (tools/monado/run) has its
# own Python, where this process's sys.executable does not exist.
PYTHON_VARIABLE = "SAND_EDITOR_VR_PYTHON"


def viewer_command(
    preset_file: Path | None,
    desktop: bool,
    scene: dict | None = None,
    extra_args: tuple[str, ...] = (),
) -> list[str]:
    """The command line that starts the viewer, wrapper first; without ``preset_file`` the
    viewer starts on its default preset.

    ``scene`` holds what the viewer starts with: ``hours``, ``day_speed`` (simulated hours per
    real second, 0 when the day is paused), ``mode`` and ``texture_size``, each optional.

    Raises
    ------
    ValueError
        When the wrapper variable cannot be split like a shell command line.
    """
    try:
        wrapper = shlex.split(os.environ.get(WRAPPER_VARIABLE, ""))
    except ValueError as error:
        raise ValueError(f"{WRAPPER_VARIABLE}: {error}") from None
    python = os.environ.get(PYTHON_VARIABLE) or sys.executable
    command = [*wrapper, python, "-m", "sand_editor", "vr", "--control", "stdio"]
    if desktop:
        command.append("--desktop")
    scene = scene or {}
    if "hours" in scene:
        minutes = round(scene["hours"] * 60.0) % (24 * 60)
        command += ["--time", f"{minutes // 60:02d}:{minutes % 60:02d}"]
    if scene.get("day_speed"):
        command += ["--day-speed", f"{scene['day_speed']:.6g}"]
    if "mode" in scene:
        command += ["--mode", scene["mode"]]
    if "texture_size" in scene:
        command += ["--texture-size", str(scene["texture_size"])]
    command += extra_args
    return command if preset_file is None else [*command, str(preset_file)]
