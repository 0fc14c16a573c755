"""Fuzzed command lines: every one ends with argparse's usage error (status 2) or one error line
(status 1), never a traceback. Outputs are folders, so nothing valid does real work."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sand_editor.cli import main

values = st.one_of(
    st.sampled_from(["0", "-1", "1e999", "nan", "inf", "25:00", "12:60", "10x10", "0x5",
                     "99999x1", "red-desert", "no-such", "a\nb", "\x1b[31m", "", "-", "--",
                     "glb", "gltf", "web", "unreal", "godot", "exr", "png16", ".", "/",
                     "١٢", "١٢:٠٠", "١٠x١٠", "1_0", " 5", "²"]),
    st.text(max_size=30),
    st.integers().map(str),
    st.floats().map(str),
)  # fmt: skip
FLAGS = {
    "render": ["--size", "--distance", "--time", "--mode", "--pitch", "--samples"],
    "bake": ["--size", "--target", "--normal-format", "--height-format"],
    "export": ["--size", "--patch", "--format"],
    "serve": ["--port", "--host"],
    "vr": ["--render-scale", "--time", "--day-speed", "--mode", "--frames", "--screenshot"],
}


@pytest.mark.parametrize("command", list(FLAGS))
@settings(
    max_examples=150,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_fuzzed_command_lines_end_in_one_documented_error(command, data, tmp_path, capsys):
    argv = [command, data.draw(values | st.just("paper-default"), label="preset")]
    chosen = {}
    for flag in data.draw(st.lists(st.sampled_from(FLAGS[command]), max_size=4), label="flags"):
        chosen[flag] = data.draw(values, label=flag)
        argv += [flag, chosen[flag]]
    # An output that exists and is a folder (render, vr, a glTF export) or a file (bake, a web
    # or Godot export, which write a folder): refused before work. serve's folder is never a web
    # export here, so it never serves.
    a_file = tmp_path / "a-file"
    a_file.write_text("")
    if command == "bake" or (command == "export" and chosen.get("--format") in ("web", "godot")):
        argv += ["--out", str(a_file)]
    elif command != "serve":
        argv += ["--report" if command == "vr" else "--out", str(tmp_path)]
    try:
        status = main(argv)
    except SystemExit as exit_:
        status = exit_.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert status in (1, 2), (argv, status, err)
    if status == 1:
        assert err.count("\n") == 1 and err.startswith(f"sand-editor {command}: error: "), err
