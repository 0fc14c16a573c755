"""One shader source for desktop GL and the web: every program the renderer, the material and
the generator compile is also valid GLSL ES 3.00 (WebGL2), checked by Khronos' reference
validator (glslangValidator) and compiled and linked by Chromium's WebGL2."""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest

from sand_editor import gl
from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.resources import BENCH_SHADERS, shader_source
from sand_editor.view import MODES
from tests.export.js_tools import CHROMIUM, compile_webgl2
from tests.render.conftest import renderer_with_material

pytestmark = pytest.mark.gl

# What a web port of the frame cannot do without.
FRAME_FILES = {"terrain.glsl", "sky.glsl", "post.glsl", "shadow_depth.glsl", "fullscreen.vert"}
SIZE = (64, 36)


def _product_programs(sand_renderer, gl_ctx) -> dict[str, tuple[str, str]]:
    """Every program of shaders/ compiled in this process, after a frame in every mode (with
    the sphere and shadows), a material rebuilt and a tile generated, as GLSL ES sources."""
    renderer = sand_renderer
    camera = camera_at_distance(
        1.0,
        35.0,
        SIZE[0] / SIZE[1],
        ground_height=lambda x, z: float(renderer.terrain.height(x, z)),
    )
    for mode in MODES:
        renderer.render_to_array(*SIZE, FrameRequest(camera, sky_at(16.5), mode, show_sphere=True))
    preset = Preset().replace(**{"generation.seed": 5})
    renderer.material.update(
        preset, grains=generate(preset, renderer.material.texture_size, ctx=gl_ctx)
    )

    programs = {}
    for vertex, fragment in sorted(gl.compiled_programs):
        files = (vertex[0], fragment[0])
        if not all(_product_shader(file) for file in files):
            continue  # the benchmark's, or a test's own source
        name = f"{vertex[0]}+{fragment[0]}{dict(fragment[1])}"
        programs[name] = (
            gl.shader_text(vertex[0], dict(vertex[1]), dialect="es"),
            gl.shader_text(fragment[0], dict(fragment[1]), dialect="es"),
        )
    return programs


def _product_shader(file: str) -> bool:
    if file.startswith(BENCH_SHADERS):
        return False
    try:
        shader_source(file)
    except FileNotFoundError:
        return False
    return True


@pytest.fixture(scope="module")
def es_programs(gl_ctx):
    with renderer_with_material(gl_ctx) as renderer:
        return _product_programs(renderer, gl_ctx)


def test_the_product_programs_are_all_collected(es_programs):
    files = {name.split("{")[0] for name in es_programs}
    stages = {part for pair in files for part in pair.split("+")}
    assert FRAME_FILES <= stages, stages
    assert {"material_build.frag", "sand_generate.frag"} <= stages
    assert any("SAND_FAR_ONLY" in name for name in es_programs)  # both surface variants
    for vertex, fragment in es_programs.values():
        assert vertex.startswith("#version 300 es\n") and fragment.startswith("#version 300 es\n")


def _require(found: bool, what: str) -> None:
    """Skip where a checker is missing, except in CI, whose set-up installs it."""
    if not found:
        (pytest.fail if os.environ.get("CI") else pytest.skip)(f"{what} is not installed")


def test_khronos_reference_validator_accepts_every_program_as_glsl_es(es_programs, tmp_path):
    _require(shutil.which("glslangValidator") is not None, "glslangValidator (glslang-tools)")
    files = []
    for i, (vertex, fragment) in enumerate(es_programs.values()):
        for text, stage in ((vertex, "vert"), (fragment, "frag")):
            path = tmp_path / f"p{i}.{stage}"
            path.write_text(text)
            files.append(str(path))
    result = subprocess.run(
        ["glslangValidator", *files], capture_output=True, text=True, timeout=300
    )
    names = {f"p{i}": name for i, name in enumerate(es_programs)}
    errors = [line for line in result.stdout.splitlines() if "ERROR" in line]
    assert result.returncode == 0, (names, errors[:20])


def test_the_same_text_is_refused_by_the_validator_without_its_es_header(tmp_path):
    # The check above can fail: the core text as ES (no precision for samplers) does not pass.
    _require(shutil.which("glslangValidator") is not None, "glslangValidator (glslang-tools)")
    core = gl.shader_text("sky.glsl", {"FRAGMENT_SHADER": 1})
    bare = core.replace(gl.CORE_VERSION, "#version 300 es", 1)
    path = tmp_path / "sky.frag"
    path.write_text(bare)
    result = subprocess.run(["glslangValidator", str(path)], capture_output=True, text=True)
    assert result.returncode != 0


def test_an_unknown_dialect_or_version_line_is_refused():
    with pytest.raises(ValueError, match="unknown GLSL dialect 'hlsl'; allowed core, es"):
        gl.shader_text("sky.glsl", dialect="hlsl")


@pytest.mark.slow
def test_chromium_webgl2_compiles_and_links_every_program(es_programs):
    _require(os.path.exists(CHROMIUM), f"Chromium ({CHROMIUM})")
    results = compile_webgl2(es_programs)
    failed = {name: r["log"] for name, r in results.items() if name != "info" and not r["linked"]}
    assert not failed, failed
    # The near surface program keeps its glints' uniforms: a port sets the renderer's names.
    near = next(
        name
        for name in es_programs
        if name.startswith("terrain.glsl+terrain.glsl") and "SAND_FAR_ONLY" not in name
    )
    uniforms = set(results[near]["uniforms"])
    glints = {"u_glint_moments", "u_facet_size", "u_texture_size", "u_uv_scale", "u_sun_direction"}
    assert glints <= uniforms, sorted(uniforms)
