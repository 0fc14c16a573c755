"""What the product's programs are made of: the benchmark's probe code is in the probe's
program and nowhere else."""

from __future__ import annotations

import pytest

from sand_editor.gl import shader_text
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
