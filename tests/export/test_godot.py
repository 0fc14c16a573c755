"""The Godot export: a Godot 4 project whose shader is the renderer's program in Godot's frame,
with the material's own textures and uniforms, compiled and drawn by Godot 4 itself (Debian sid's,
in tools/godot/run) with both its Compatibility and Forward+ renderers, against our frames."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sand_editor import gl
from sand_editor.bench import godot as godot_bench
from sand_editor.bench import web as web_bench
from sand_editor.bench.sweep import random_preset
from sand_editor.export.godot import (
    DRAWS_EVERY_DISTANCE,
    PROJECT_FILES,
    SCENE_FILE,
    SHADER_FILE,
    SKY_SHADER_FILE,
    GodotShaderError,
    export_godot,
    fragment_stage,
    godot_sky_shader,
    matrix_columns,
    shader_uniforms,
)
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial, surface_defines
from sand_editor.resources import bundled_preset
from tests.chroot_harness import built_harness

pytestmark = pytest.mark.gl
SMALL = 64
BUILD_TIMEOUT = 900
_FUNCTION = re.compile(r"^\w+\s+(\w+)\s*\([^;{]*\)\s*\{", re.MULTILINE)


@pytest.fixture(scope="module")
def project(tmp_path_factory, gl_ctx):
    folder = tmp_path_factory.mktemp("godot") / "sand"
    export_godot(Preset.load(bundled_preset("red-desert")), folder, SMALL, ctx=gl_ctx)
    return folder


@pytest.fixture(scope="session")
def godot_harness() -> Path:
    return built_harness(godot_bench.GODOT_RUN, "the Godot harness", BUILD_TIMEOUT)


def _scene(folder: Path) -> dict:
    return json.loads((folder / SCENE_FILE).read_text())


def test_the_shader_is_the_renderers_program_in_godots_frame(project):
    shader = (project / SHADER_FILE).read_text()
    # The renderer's fragment program (its stage blocks resolved as tested below).
    core = fragment_stage(gl.shader_text("terrain.glsl", surface_defines()))
    assert shader.startswith("shader_type spatial;\nrender_mode unshaded")
    for gone in (r"^#version", r"^#line", r"^in\s", r"^out\s", r"\bvoid main\("):
        assert not re.search(gone, shader, re.MULTILINE), gone
    assert shader.count("void vertex()") == 1 and shader.count("void fragment()") == 1
    # Every function and uniform of the renderer's fragment program, none made up (but the
    # two the Godot frame adds, and main, which is fragment()).
    functions = set(_FUNCTION.findall(shader))
    display = {"aces_fitted", "aces_over_spread"}  # the editor's tone curve (tone.glsl)
    assert functions == set(_FUNCTION.findall(core)) - {"main"} | display | {"vertex", "fragment"}
    ours = set(shader_uniforms(core))
    assert set(shader_uniforms(shader)) == ours | {"u_exposure", "u_editor_look"}
    # The integer grain texture is read as exact floats; the others keep their filters.
    assert "uniform sampler2D u_layer_grain : filter_nearest, repeat_enable;" in shader
    assert "uniform sampler2D u_glint_moments : filter_linear_mipmap, repeat_enable;" in shader
    assert "sampler3D u_relief_visibility : filter_linear, repeat_disable;" in shader


def test_the_sky_is_the_renderers_sky_program_in_godots_frame():
    sky = godot_sky_shader()
    core = fragment_stage(gl.shader_text("sky.glsl", {}))
    assert sky.startswith("shader_type sky;\n")
    assert "sky_radiance(EYEDIR)" in sky and "gl_FragCoord" not in sky
    assert set(_FUNCTION.findall(sky)) == set(_FUNCTION.findall(core)) - {"main"} | {
        "aces_fitted", "aces_over_spread", "sky"}  # fmt: skip
    assert set(shader_uniforms(sky)) == set(shader_uniforms(core)) | {"u_exposure",
                                                                      "u_editor_look"}  # fmt: skip


def test_the_stage_blocks_resolve_for_the_fragment_and_other_directives_stay():
    text = "\n".join([
        "uniform float a;",
        "#if defined VERTEX_SHADER",
        "out vec3 v;",
        "#if defined SAND_PROBE",
        "float probe_v;",
        "#endif",
        "#elif defined FRAGMENT_SHADER",
        "in vec3 v;",
        "#if defined SAND_PROBE",
        "float probe_f;",
        "#else",
        "float plain_f;",
        "#endif",
        "#endif",
        "#ifdef X",
        "float x;",
        "#endif",
    ])  # fmt: skip
    kept = fragment_stage(text).split("\n")
    assert kept == [
        "uniform float a;", "in vec3 v;", "#if defined SAND_PROBE", "float probe_f;", "#else",
        "float plain_f;", "#endif", "#ifdef X", "float x;", "#endif",
    ]  # fmt: skip
    assert fragment_stage("#if defined(VERTEX_SHADER)\nint v;\n#else\nint f;\n#endif") == "int f;"
    with pytest.raises(GodotShaderError):
        fragment_stage("#if defined VERTEX_SHADER\nint v;\n")


def test_scalar_matrices_become_columns_and_others_stay():
    assert matrix_columns("mat2(0.0, 1.0, 1.0, 0.0)") == "mat2(vec2(0.0, 1.0), vec2(1.0, 0.0))"
    nine = "mat3(a, f(b, c), 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0)"
    assert matrix_columns(nine) == (
        "mat3(vec3(a, f(b, c), 3.0), vec3(4.0, 5.0, 6.0), vec3(7.0, 8.0, 9.0))"
    )
    for kept in ("mat2(1.0)", "mat3(x, y, z)", "mat2(s.x, 0.0, 0.0, s.y) * mat2(1.0)"):
        assert matrix_columns(kept).replace(" ", "") == (
            kept if "s.x" not in kept else "mat2(vec2(s.x,0.0),vec2(0.0,s.y))*mat2(1.0)"
        ).replace(" ", "")
    # A matrix inside a matrix's argument is rewritten too.
    assert matrix_columns("mat2(mat2(1,2,3,4)[0], 0.0, 1.0)").startswith(
        "mat2(mat2(vec2(1, 2), vec2(3, 4))[0]"
    )


def test_the_grain_identities_cross_as_exact_floats(project, gl_ctx):
    scene = _scene(project)
    entry = next(t for t in scene["material"]["textures"] if t["uniform"] == "u_layer_grain")
    assert entry["image_format"] == "FORMAT_RGBAF" and len(entry["levels"]) == 1
    floats = np.fromfile(project / entry["file"], dtype=np.float32).reshape(SMALL, SMALL, 4)
    material = SandMaterial(gl_ctx, SMALL)
    try:
        material.update(Preset.load(bundled_preset("red-desert")))
        texture = material.textures()["u_layer_grain"]
        pairs = np.frombuffer(texture.read(), dtype=np.uint32).reshape(SMALL, SMALL, 2)
    finally:
        material.release()
    # What layer_and_grain does in the shader: round each float, join the halves.
    v = (floats[..., :3] + np.float32(0.5)).astype(np.uint32)
    assert np.array_equal(v[..., 0], pairs[..., 0])
    assert np.array_equal(v[..., 1] | (v[..., 2] << np.uint32(16)), pairs[..., 1])
    assert pairs[..., 1].max() > 1 << 24  # identities use all 32 bits: the split is needed


def test_the_project_holds_the_material_the_renderer_binds(project, gl_ctx):
    scene = _scene(project)
    names = sorted(p.name for p in project.iterdir() if not p.name.startswith("."))
    assert set(PROJECT_FILES) | {SHADER_FILE, SKY_SHADER_FILE, SCENE_FILE} <= set(names)
    material = SandMaterial(gl_ctx, SMALL)
    try:
        material.update(Preset.load(bundled_preset("red-desert")))
        values = material.uniform_values()
    finally:
        material.release()
    declared = shader_uniforms((project / SHADER_FILE).read_text())
    uniforms = {u["name"]: u for u in scene["material"]["uniforms"]}
    for name, value in values.items():
        if name not in declared:
            continue  # the material's build program's, not the surface's
        assert uniforms[name]["type"] == declared[name]
        expected = DRAWS_EVERY_DISTANCE.get(name, value)
        assert np.allclose(np.asarray(uniforms[name]["value"], float), expected), name
    assert uniforms["u_tile_variation"]["value"] == 1 and uniforms["u_mode"]["value"] == 0
    table = scene["sky"]["table"]
    assert {n for row in table for n in row["uniforms"]} <= set(declared)
    sky_declared = shader_uniforms((project / SKY_SHADER_FILE).read_text())
    constants = {u["name"] for u in scene["sky"]["constants"]}
    assert constants == {"u_ground_albedo", "u_gradient_exponent", "u_sun_radius",
                         "u_moon_radius"}  # fmt: skip
    # Every uniform of the sky is set: by the day's table, the constants or the export's frame
    # (the screen's inverse projection and size are Godot's EYEDIR there).
    by_time = {n for row in table for n in row["sky_uniforms"]}
    assert by_time | constants | {"u_exposure", "u_editor_look", "u_inverse_view_projection",
                                  "u_resolution"} == set(sky_declared)  # fmt: skip
    assert all(row["exposure"] > 0 for row in table)
    assert "programs" not in scene  # the page's GLSL ES stays with the web export


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, driver",
    # Black sand on Forward+: Godot's Compatibility renderer writes the darkest tones darker
    # (README, "The sand in Godot").
    [("paper-default", "opengl3"), ("paper-default", "vulkan"), ("black-volcanic", "vulkan"),
     ("random", "opengl3")],
)  # fmt: skip
def test_godot_draws_what_the_renderer_draws(name, driver, godot_harness, gl_ctx, tmp_path):
    if name == "random":
        preset = random_preset(np.random.default_rng(28), "random-28")
    else:
        preset = Preset.load(bundled_preset(name))
    # godot_frames fails on any shader or GL error Godot reports.
    result = godot_bench.compare(preset, gl_ctx, driver, folder=tmp_path)
    assert godot_bench.DRIVERS[driver] in result["info"]["renderer"]
    for row in result["rows"]:
        assert row["flip"] <= web_bench.FLIP_TARGET, row
        assert web_bench.sparkles_agree(row, "godot"), row
    if name == "paper-default":  # glinty sand glints in Godot too
        assert max(row["sparkle_godot"] for row in result["rows"]) >= 0.002
    ours, drawn = result["frames"]["ours"], result["frames"]["godot"]
    ground = slice(ours.shape[1] // 2, None)
    assert abs(float(drawn[:, ground].mean()) - float(ours[:, ground].mean())) < 4.0


@pytest.mark.slow
@pytest.mark.parametrize("driver", ["opengl3", "vulkan"])
def test_godot_draws_the_renderers_sky_by_day_and_night(driver, godot_harness, gl_ctx, tmp_path):
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.terrain import DuneTerrain

    terrain = DuneTerrain()
    cameras = [
        (camera_at_distance(30.0, 3.0, 16 / 9, lambda x, z: float(terrain.height(x, z)),
                            heading_deg=heading), hours)
        for heading, hours in ((0.0, 12.0), (90.0, 21.0))
    ]  # fmt: skip
    preset = Preset.load(bundled_preset("paper-default"))
    export_godot(preset, tmp_path / "sand", SMALL, ctx=gl_ctx)
    drawn = godot_bench.godot_frames(tmp_path / "sand", cameras, driver)["frames"]
    ours, _ = web_bench.renderer_frames(gl_ctx, preset, cameras, texture_size=SMALL)
    sky = slice(0, 40)  # above every dune in these views
    for mine, theirs in zip(ours, drawn, strict=True):
        difference = np.abs(theirs[sky].mean(axis=(0, 1)) - mine[sky].mean(axis=(0, 1)))
        assert difference.max() < 3.5, difference
    noon, night = drawn[0][sky].mean(axis=(0, 1)), drawn[1][sky].mean(axis=(0, 1))
    assert noon[2] > noon[0] + 30 and night.max() < 0.6 * noon.max()  # blue by day, dark by night


@pytest.mark.slow
def test_the_demo_a_user_opens_shows_the_sand_and_its_time_slider(godot_harness, project):
    shot = project / "demo.png"
    done = subprocess.run(
        [str(godot_harness), "--timeout", "120", "--size", "640x360", str(project), "--",
         "--screenshot", "res://demo.png"],
        capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    output = done.stdout + done.stderr
    assert done.returncode == 0, output[-2000:]
    assert not [line for line in output.splitlines() if godot_bench.FAILURE.search(line)], output
    image = np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)
    assert image.shape == (360, 640, 3)
    sky, ground = image[2:8, 450:630], image[200:350, 50:600]
    assert sky[..., 2].mean() > sky[..., 0].mean()  # the sky's colour behind the dunes
    assert ground[..., 0].mean() > ground[..., 2].mean() + 20  # red-desert's sand, lit
    assert ground.std() > 2.0  # grains and ripples, not a flat fill
    # The time of day: its label and slider across the top left.
    controls = image[15:40, 10:390]
    assert controls.max() > 200 and controls.std() > 20


def test_a_broken_view_list_ends_the_capture_with_an_error(godot_harness, project):
    (project / "broken.json").write_text('{"not": "a list"}')
    done = subprocess.run(
        [str(godot_harness), "--timeout", "120", str(project), "--",
         "--views", "res://broken.json", "--capture", "res://"],
        capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert done.returncode == 1
    assert "holds no list of views" in done.stdout + done.stderr


def test_the_bench_table_says_where_godot_and_the_renderer_disagree():
    row = {
        "preset": "black-volcanic",
        "distance_m": 0.3,
        "flip": 0.07,
        "sparkle_ours": 0.0015,
        "sparkle_godot": 0.0027,
        "ms_ours": 88.0,
        "ms_godot": None,
        "renderer": "Forward+",
    }
    results = {
        "machine": {"cpu_model": "CPU", "cpu_count": 2, "gl_renderer": "llvmpipe"},
        "godot": {"Forward+": "Vulkan - Forward+ - lavapipe"},
        "size": [320, 180], "texture_size": 512, "pitch_deg": 25.0,
        "rows": [row, {**row, "distance_m": 3.0, "sparkle_godot": 0.0015, "flip": 0.02}],
    }  # fmt: skip
    table = godot_bench.format_table(results)
    assert "| Forward+ | black-volcanic | 0.3 m | 0.070 | 0.0015 | 0.0027 | 88 | – |" in table
    assert "| Godot renderer | sand |" in table and "Godot Forward+: Vulkan" in table
    assert table.endswith("worst FLIP 0.070 (target ≤ 0.1); sparkle shares within 25%: no")
    results["rows"] = results["rows"][1:]
    assert godot_bench.format_table(results).endswith("within 25%: yes")


@pytest.mark.parametrize(
    "args, said",
    [(["--driver", "metal"], "--driver takes opengl3 or vulkan"),
     (["--size", "0x5"], "--size takes WIDTHxHEIGHT"),
     (["--frames", "many"], "--frames needs a whole number"),
     (["/no/such/folder"], "no project folder"),
     (["."], "holds no project.godot")],
)  # fmt: skip
def test_the_godot_harness_refuses_what_it_cannot_run(godot_harness, args, said):
    done = subprocess.run([str(godot_harness), *args], capture_output=True, text=True, timeout=60)
    assert done.returncode == 125 and said in done.stderr, done.stderr
