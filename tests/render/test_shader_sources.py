"""What the product's programs are made of: the benchmark's probe code is in the probe's
program and nowhere else; every line keeps its file's own line number, so that a compile error
names the file and line it is in; each fact Python and GLSL share is written once, in Python,
and reaches the shaders as a #define."""

from __future__ import annotations

import re

import moderngl
import pytest

from sand_editor import colour
from sand_editor.generator import noise
from sand_editor.gl import (
    UniformError,
    compiled_programs,
    fullscreen_program,
    program,
    set_uniform,
    shader_text,
    source_line,
)
from sand_editor.preset import FIELDS
from sand_editor.render import far_brdf, material, shadows
from sand_editor.render.modes import mode_defines
from sand_editor.resources import bench_shaders_dir, shader_source, shaders_dir

# Every table of facts Python hands the shaders.
FACT_TABLES = {
    "colour": colour.SHADER_DEFINES,
    "far_brdf": far_brdf.SHADER_DEFINES,
    "material": material.SHADER_DEFINES,
    "noise": noise.SHADER_DEFINES,
    "shadows": shadows.SHADER_DEFINES,
    "modes": mode_defines(),
}
SHADER_FILES = sorted([*shaders_dir().glob("*.*"), *bench_shaders_dir().glob("*.*")])


def _code(path) -> str:
    """A shader file without its comments."""
    text = path.read_text(encoding="utf-8")
    return re.sub(r"/\*.*?\*/", "", re.sub(r"//[^\n]*", "", text), flags=re.S)


def _copies(code: str, value) -> bool:
    """Whether ``code`` writes ``value`` as a number of five or more significant digits."""
    digits = re.sub(r"[^0-9]", "", str(value)).strip("0")
    literal = re.compile(rf"(?<![\w.]){re.escape(str(value))}(?![\w])")
    return len(digits) >= 5 and literal.search(code) is not None


@pytest.mark.parametrize("table", FACT_TABLES)
def test_no_shader_writes_again_a_fact_python_defines(table):
    for name, value in FACT_TABLES[table].items():
        declared = re.compile(rf"(\bconst\s+\w+\s+{name}\b|#\s*define\s+{name}\b)")
        for path in SHADER_FILES:
            code = _code(path)
            assert not declared.search(code), f"{path.name} declares {name} of {table}"
            assert not _copies(code, value), f"{path.name} copies {name} = {value}"


@pytest.mark.parametrize("table", FACT_TABLES)
def test_every_fact_python_defines_is_read_by_a_shader(table):
    codes = [_code(path) for path in SHADER_FILES]
    for name in FACT_TABLES[table]:
        if name.startswith("MODE_"):
            continue  # the modes are all #defined; a shader reads those it has a branch for
        assert any(re.search(rf"\b{name}\b", code) for code in codes), f"{name} is read nowhere"


def test_a_number_copied_into_a_shader_is_caught(tmp_path):
    copied = tmp_path / "copy.glsl"
    copied.write_text("float f(float x) { return x * 4.50996; } // DEON_SPREAD_SCALE\n")
    assert _copies(_code(copied), far_brdf.SHADER_DEFINES["DEON_SPREAD_SCALE"])
    assert not _copies(_code(copied), far_brdf.SHADER_DEFINES["FACING_BAND"])  # 0.15: too short
    assert "DEON_SPREAD_SCALE" not in _code(copied)  # the comment is not code


# Definitions of the probe's own uniforms and functions (the product calls none of them).
PROBE_ONLY = (
    "uniform int u_glint_filter",
    "vec2 ground_truth_factors(",
    "vec2 probe_glint_factors(",
    "vec2 stratum_offset(",
)


@pytest.mark.parametrize("variant", [{}, {"SAND_FAR_ONLY": 1}])
@pytest.mark.parametrize("stage", ["VERTEX_SHADER", "FRAGMENT_SHADER"])
def test_the_products_surface_programs_hold_no_probe_code(variant, stage):
    source = shader_text("terrain.glsl", {**mode_defines(), **variant, stage: 1})
    for name in PROBE_ONLY:
        assert name not in source


def test_the_probes_program_holds_its_filters():
    source = shader_text("terrain.glsl", {**mode_defines(), "SAND_PROBE": 1, "FRAGMENT_SHADER": 1})
    for name in PROBE_ONLY:
        assert name in source


def _declared(file: str) -> set[str]:
    return set(re.findall(r"^\s*uniform\s+\w+\s+(\w+)", shader_text(file), flags=re.M))


def test_every_shading_field_is_a_uniform_the_surface_declares_and_uses(gl_clean):
    from sand_editor.render.material import SHADER_DEFINES, surface_defines

    declared = _declared("sand_surface.glsl")
    programs = [program(gl_clean, "terrain.glsl", surface_defines(**variant))
                for variant in ({}, {"SAND_FAR_ONLY": 1})]  # fmt: skip
    programs.append(fullscreen_program(gl_clean, "material_build.frag", SHADER_DEFINES))
    try:
        active = {name for p in programs for name in p}
        build = set(programs[-1])
        unused = []
        for spec in FIELDS:
            if spec.section != "shading":
                continue
            assert spec.uniform == f"u_{spec.name}", spec.path
            where = "material_build.frag" if spec.cost == "moments" else "sand_surface.glsl"
            assert spec.uniform in _declared(where), f"{spec.path}: {where} lacks its uniform"
            if spec.uniform not in active:
                unused.append(spec.path)
            # A field whose change rebuilds the moments is the one the build reads.
            assert (spec.cost == "moments") == (spec.uniform in build), spec.path
        assert unused == [], f"no production program uses {unused}"
        # And the other way: a uniform named like a field is that field's.
        names = {s.name for s in FIELDS if s.section == "shading"}
        field_like = {n for n in declared | _declared("material_build.frag") if n[2:] in names}
        assert field_like == {s.uniform for s in FIELDS if s.uniform}
    finally:
        for p in programs:
            p.release()


def test_a_uniform_no_shader_declares_raises_and_an_unused_one_is_skipped(gl_clean):
    from sand_editor.render.material import surface_defines

    far = program(gl_clean, "terrain.glsl", surface_defines(SAND_FAR_ONLY=1))
    try:
        # Declared, but only the close range's taps along a grazing footprint read it.
        assert "u_anisotropic" not in far
        set_uniform(far, "u_anisotropic", 1)
        with pytest.raises(UniformError, match="u_anisotropicc"):
            set_uniform(far, "u_anisotropicc", 1)
        set_uniform(far, "u_sigmoid_a", 3.0)
        assert far["u_sigmoid_a"].value == 3.0
    finally:
        far.release()


@pytest.mark.parametrize(
    ("name", "defines"),
    [
        ("terrain.glsl", {**mode_defines(), "FRAGMENT_SHADER": 1}),
        ("terrain.glsl", {**mode_defines(), "SAND_PROBE": 1, "FRAGMENT_SHADER": 1}),
        ("terrain.glsl", {**mode_defines(), "VERTEX_SHADER": 1}),
        ("post.glsl", {"RESOLVE": 1}),
        ("fullscreen.vert", None),
    ],
)
def test_every_line_of_a_program_maps_back_to_its_file_and_line(name, defines):
    source = shader_text(name, defines)
    files, line, checked = set(), None, 0
    for text in source.split("\n")[1:]:  # after #version, line 1 of the first file
        directive = re.fullmatch(r"#line (\d+)", text)
        if directive:
            line = int(directive.group(1))
            continue
        if line is None:  # the defines, before the first file's line 2
            assert text.startswith("#define "), text
            continue
        where = source_line(name, defines, line)
        file, own = where.removeprefix("shaders/").rsplit(":", 1)
        original = shader_source(file).split("\n")[int(own) - 1]
        # An include's line is empty where its file is dropped (included before, or not defined).
        assert text == original or (not text and "#include" in original), (where, text)
        files.add(file)
        checked += 1
        line += 1
    assert name in files and checked >= shader_source(name).count("\n")
    if name == "terrain.glsl":
        assert {"common.glsl", "sand_surface.glsl", "shadows.glsl"} <= files


def test_a_compile_error_names_the_included_file_and_its_line(gl_clean):
    # MAX_HALF is declared on line 5 of common.glsl, which post.glsl includes: defined away,
    # that declaration fails to compile.
    assert shader_source("common.glsl").split("\n")[4].startswith("const float MAX_HALF")
    with pytest.raises(moderngl.Error) as caught:
        fullscreen_program(gl_clean, "post.glsl", {"RESOLVE": 1, "MAX_HALF": "+"})
    assert "shaders/common.glsl:5:" in str(caught.value)
    # A program that failed is not one a port must compile (test_glsl_es.py checks them all).
    broken = [p for p in compiled_programs if ("MAX_HALF", "+") in p[1][1]]
    assert not broken, broken
