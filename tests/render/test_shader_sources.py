"""What the product's programs are made of: the benchmark's probe code is in the probe's
program and nowhere else."""

from __future__ import annotations

import re

import pytest

from sand_editor.gl import UniformError, fullscreen_program, program, set_uniform, shader_text
from sand_editor.preset import FIELDS
from sand_editor.render.modes import mode_defines

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
        # Declared, but only the close range's sparkle placement reads it.
        assert "u_texture_size" not in far
        set_uniform(far, "u_texture_size", 1024.0)
        with pytest.raises(UniformError, match="u_texture_sizee"):
            set_uniform(far, "u_texture_sizee", 1024.0)
        set_uniform(far, "u_sigmoid_a", 3.0)
        assert far["u_sigmoid_a"].value == 3.0
    finally:
        far.release()
