"""What the harnesses that run a program in a cached Debian root need of this machine
(tools/monado/run, tools/godot/run), and their session fixtures' shared start."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def missing_prerequisite(harness: str) -> str | None:
    """Why ``harness`` cannot run here, or None."""
    if not sys.platform.startswith("linux"):
        return f"{harness} needs Linux"
    if os.geteuid() != 0:
        return f"{harness} needs root (debootstrap, chroot, mount namespaces)"
    for tool in ("debootstrap", "unshare", "setpriv", "chroot", "flock"):
        if shutil.which(tool) is None:
            return f"{harness} needs {tool}, which is not installed"
    probe = subprocess.run(
        ["unshare", "--mount", "--pid", "--fork", "--net", "true"],
        capture_output=True,
        text=True,
    )
    if probe.returncode != 0:
        return f"unshare is not permitted here: {probe.stderr.strip()}"
    return None


def built_harness(run: Path, harness: str, timeout_s: float) -> Path:
    """``run`` with its cached root built; skips where it cannot exist, fails in CI."""
    reason = missing_prerequisite(harness)
    if reason:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true but {reason}")
        pytest.skip(reason)
    build = subprocess.run(
        [str(run), "--build-only"], capture_output=True, text=True, timeout=timeout_s
    )
    assert build.returncode == 0, f"building the root of {harness} failed:\n{build.stderr}"
    return run
