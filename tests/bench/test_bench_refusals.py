"""What ``sand-editor bench`` refuses before it measures anything: a missing package of the
``bench`` extra, no display for a Qt benchmark, and a ``--json`` or ``--plot`` path it could
not write. Each is one line on stderr and exit status 1, with no table printed."""

from __future__ import annotations

import json
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


@pytest.mark.parametrize(
    ("option", "what", "target", "reason"),
    [
        ("--json", "export", "a-folder", "is a folder"),
        ("--json", "export", "a-file/results.json", "Not a directory"),
        ("--plot", "generator", "a-folder", "is a folder"),
    ],
)
def test_an_output_that_cannot_be_written_is_refused_before_the_run(
    tmp_path, option, what, target, reason
):
    (tmp_path / "a-folder").mkdir()
    (tmp_path / "a-file").write_text("kept")
    result = bench(what, option, str(tmp_path / target))
    assert_one_line_refusal(result, f"{option} {tmp_path / target}: ", reason)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "a-folder"]
    assert list((tmp_path / "a-folder").iterdir()) == []


def test_results_are_written_whole_into_folders_made_for_them(tmp_path):
    from sand_editor.bench._report import report

    path = tmp_path / "runs" / "first" / "results.json"
    assert report({"ms": [1.5, 2.0]}, lambda r: "table", lambda r, p: None, str(path)) == 0
    assert json.loads(path.read_text()) == {"ms": [1.5, 2.0]}
    assert [p.name for p in path.parent.iterdir()] == ["results.json"]  # no temporary left
