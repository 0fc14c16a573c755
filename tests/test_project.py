"""The project's own promises: architecture contracts, style, packaging, and the README."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def run(*args, cwd=ROOT, env=None, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(a) for a in args], capture_output=True, text=True, cwd=cwd, env=env, timeout=timeout
    )


def test_import_contracts_hold():
    """The model and maths import no Qt/OpenXR/GL; only the app shell imports Qt."""
    result = run(BIN / "lint-imports", "--no-cache")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout


def test_model_imports_nothing_heavy():
    code = (
        "import sys, sand_editor, sand_editor.preset, sand_editor.generator.noise,"
        " sand_editor.generator.reference; print(sorted({m.split('.')[0] for m in sys.modules}"
        " & {'PySide6', 'moderngl', 'xr', 'glcontext'}))"
    )
    result = run(sys.executable, "-c", code)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_ruff_lint_and_format_are_clean():
    lint = run(BIN / "ruff", "check", ".")
    assert lint.returncode == 0, lint.stdout
    fmt = run(BIN / "ruff", "format", "--check", ".")
    assert fmt.returncode == 0, fmt.stdout


@pytest.mark.slow
@pytest.mark.gl
def test_wheel_carries_its_resources_and_works_outside_the_checkout(tmp_path):
    built = run(sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", tmp_path, ROOT)
    assert built.returncode == 0, built.stderr
    (wheel,) = tmp_path.glob("sand_editor-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for resource in (
        "sand_editor/shaders/sand_generate.frag",
        "sand_editor/shaders/fullscreen.vert",
        "sand_editor/presets/paper-default.json",
        "sand_editor/ui/editor.qss",
    ):
        assert resource in names
    site = tmp_path / "site"
    installed = run(
        sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", site, wheel
    )
    assert installed.returncode == 0, installed.stderr
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {**os.environ, "PYTHONPATH": str(site)}
    code = "import sand_editor, sys; print(sand_editor.__file__)"
    where = run(sys.executable, "-c", code, cwd=elsewhere, env=env)
    assert where.stdout.startswith(str(site)), where.stdout + where.stderr
    baked = run(
        sys.executable, "-m", "sand_editor", "bake", "pale-quartz", "--size", "64", "--out", "o",
        cwd=elsewhere, env=env,
    )  # fmt: skip
    assert baked.returncode == 0, baked.stderr
    assert (elsewhere / "o" / "material.json").is_file()


def test_readme_has_exactly_two_setup_commands_and_ci_runs_the_test_one():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Set up and run", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```sh\n(.*?)```", section, flags=re.S)
    commands = [
        line.split("#", 1)[0].strip() for b in blocks for line in b.splitlines() if line.strip()
    ]
    assert commands == ["tools/run-editor", "tools/run-tests"]
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert re.search(r"^exec tools/run-tests$", ci, flags=re.M)
    for script in commands:
        assert os.access(ROOT / script, os.X_OK), f"{script} must be executable"


def test_colour_facts_are_written_once():
    # The luminance weights and the sRGB curve's knees live in sand_editor/colour.py alone; the
    # shaders get the weights as a #define (the GLSL encoder of common.glsl is the one copy of
    # the curve on the GPU side).
    owners = {ROOT / "sand_editor" / "colour.py", ROOT / "shaders" / "common.glsl"}
    facts = re.compile(r"0\.7152|0\.04045")
    copies = [
        str(path.relative_to(ROOT))
        for folder in ("sand_editor", "shaders")
        for path in sorted((ROOT / folder).rglob("*"))
        if path.suffix in (".py", ".glsl", ".frag", ".vert")
        and path not in owners
        and facts.search(path.read_text(encoding="utf-8"))
    ]
    assert copies == []


def test_no_package_imports_another_packages_private_modules():
    # A package's ``_module`` is its own business: others use what its __init__ exports.
    import ast

    found = []
    for path in sorted((ROOT / "sand_editor").rglob("*.py")):
        here = path.relative_to(ROOT / "sand_editor").parts
        own = here[0] if len(here) > 1 else None
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            for name in names:
                parts = name.split(".")
                if len(parts) >= 3 and parts[0] == "sand_editor" and parts[2].startswith("_"):
                    if parts[1] != own:
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno} imports {name}")
    assert found == []
