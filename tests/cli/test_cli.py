"""The sand-editor command line: help, dispatch and preset resolution."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sand_editor.cli import main, preset_path
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


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["bake", "paper-default", "--size", "١٠٢٤"], "--size"),
        (["export", "paper-default", "--size", "1_024"], "--size"),
        (["export", "paper-default", "--patch", "١.٥"], "--patch"),
        (["render", "paper-default", "--size", "١٠x١٠"], "--size"),
        (["render", "paper-default", "--distance", "٢"], "--distance"),
        (["render", "paper-default", "--samples", "٢"], "--samples"),
        (["vr", "--frames", "١"], "--frames"),
        (["vr", "--render-scale", "٠.٥"], "--render-scale"),
        (["bench", "generator", "--sizes", "٦٤"], "--sizes"),
    ],
)
def test_numbers_in_other_scripts_digits_are_usage_errors(argv, option, tmp_path, capsys):
    out = [] if argv[0] in ("vr", "bench") else ["--out", str(tmp_path / "out")]
    with pytest.raises(SystemExit) as exit_:
        main([*argv, *out])  # int() and float() would read each of these as a number
    assert exit_.value.code == 2
    assert f"argument {option}: " in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["render", "vr"])
def test_a_time_in_other_scripts_digits_is_one_error_line(command, tmp_path, capsys):
    out = tmp_path / "frame.png"
    argv = [command, "paper-default", "--time", "١٢:٠٠"]
    argv += ["--out", str(out)] if command == "render" else ["--frames", "1"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"sand-editor {command}: error: time of day")
    assert not out.exists()


@pytest.mark.parametrize(
    ("argv", "refused"),
    [
        (["band", "--plot", "p.png"], "--plot does not apply to the band benchmark"),
        (["depth", "--sizes", "64"], "--sizes does not apply to the depth benchmark"),
        (
            ["export", "--sizes", "64", "--plot", "p.png"],
            "--sizes and --plot do not apply to the export benchmark",
        ),  # fmt: skip
        (["gpu", "--plot", "p.png"], "--plot does not apply to the gpu benchmark"),
    ],
)
def test_a_benchmark_refuses_the_options_it_does_not_take_before_it_runs(
    argv, refused, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    assert main(["bench", *argv]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and refused in err
    assert list(tmp_path.iterdir()) == []


def test_every_benchmark_names_a_module_with_a_main_taking_its_options():
    import importlib
    import inspect

    from sand_editor.cli import BENCHMARKS

    for name, (module_name, options) in BENCHMARKS.items():
        module = importlib.import_module(f"sand_editor.bench.{module_name}")
        taken = set(inspect.signature(module.main).parameters)
        wanted = {"quick", "json_path"} | {"plot_path" if o == "plot" else o for o in options}
        assert wanted <= taken, (name, wanted - taken)
