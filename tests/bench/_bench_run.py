"""What the bench tests share (imported by name, as the tests beside it are): running a
``sand-editor bench`` command as a user would."""

from __future__ import annotations

import subprocess
import sys


def run_bench(what: str, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """``sand-editor bench WHAT --quick ARGS`` in a fresh interpreter; fails with its stderr."""
    result = subprocess.run(
        [sys.executable, "-m", "sand_editor", "bench", what, "--quick", *args],
        capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    return result
