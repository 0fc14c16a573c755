"""What ``sand-editor bench`` refuses before it measures anything: a missing package of the
``bench`` extra, no display for a Qt benchmark, and a ``--json`` or ``--plot`` path it could
not write. Each is one line on stderr and exit status 1, with no table printed."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import sand_editor

REPO = Path(sand_editor.__file__).resolve().parents[1]
ERROR = "sand-editor bench: error: "


def bench(*args: str, env: dict[str, str] | None = None, blocked: Path | None = None):
    """``sand-editor bench ARGS --quick`` in a fresh interpreter of this checkout; ``blocked``,
    a folder of modules put before every other on the path."""
    env = dict(os.environ if env is None else env)
    env["PYTHONPATH"] = os.pathsep.join(str(p) for p in (blocked, REPO) if p is not None)
    return subprocess.run(
        [sys.executable, "-m", "sand_editor", "bench", *args, "--quick"],
        capture_output=True, text=True, timeout=120, env=env, cwd=REPO,
    )  # fmt: skip


def assert_one_line_refusal(result: subprocess.CompletedProcess, *fragments: str) -> str:
    assert result.returncode == 1, result.stderr[-3000:]
    assert result.stdout == "", "the benchmark ran before it was refused"
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(ERROR), result.stderr[-3000:]
    for fragment in fragments:
        assert fragment in lines[0]
    return lines[0]


@pytest.mark.parametrize(
    ("what", "module", "package"),
    [
        ("relief", "mitsuba", "mitsuba"),
        ("relief", "drjit", "mitsuba"),
        ("appearance", "mitsuba", "mitsuba"),
        ("depth", "flip_evaluator", "flip-evaluator"),
        ("generator", "matplotlib", "matplotlib"),
        ("render", "matplotlib", "matplotlib"),
    ],
)
def test_a_missing_bench_package_is_one_line_naming_the_extra(tmp_path, what, module, package):
    blocked = tmp_path / "blocked"
    blocked.mkdir()
    # Shadows the installed package: importing it fails as it does where it is not installed.
    (blocked / f"{module}.py").write_text(f"raise ImportError('no {module} here')\n")
    plot = tmp_path / "plot.png"
    result = bench(what, "--plot", str(plot), blocked=blocked)
    assert_one_line_refusal(
        result, f"the package {package}", f"no {module} here", "pip install 'sand-editor[bench]'"
    )
    assert not plot.exists()


@pytest.mark.parametrize("what", ["editor", "vr-link"])
def test_a_qt_benchmark_without_a_display_says_so_in_one_line(what):
    # Qt's xcb plugin would abort the process (exit -6) on a QApplication with no X server.
    hidden = ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")
    result = bench(what, env={k: v for k, v in os.environ.items() if k not in hidden})
    assert_one_line_refusal(result, "no display found", "xvfb-run")
