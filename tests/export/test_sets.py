"""``sand-editor bake --target``: each engine's texture set, its packing, normal handedness,
names, bit depths and README; the maps themselves (base colour, roughness, occlusion, specular)
and the numerical hard cases of the far field's Lambertian equivalent."""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sand_editor.bake import BakeSteps, bake
from sand_editor.cli import main, run_with_progress
from sand_editor.export import maps as material
from sand_editor.export.images import decode
from sand_editor.export.sets import TARGETS, MapFormats, texture_set
from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.render.far_brdf import far_radiance_per_irradiance, lambert_equivalent_albedo
from sand_editor.resources import bundled_preset

SIZE = 64


@pytest.fixture(scope="module")
def red():
    preset = Preset.load(bundled_preset("red-desert"))
    textures = generate(preset, SIZE, backend="reference")
    return preset, textures, material.material_maps(preset, textures)


def test_the_maps_are_bounded_and_finite(red):
    preset, textures, maps = red
    for name in ("base_color", "normal", "roughness", "specular", "occlusion", "height"):
        values = getattr(maps, name)
        assert values.dtype == np.float32 and np.all(np.isfinite(values)), name
    assert np.all((maps.base_color >= 0) & (maps.base_color <= 1))
    assert np.all((maps.occlusion >= 0) & (maps.occlusion <= 1))
    assert np.all(maps.specular[textures.layer < 0] == 0.0), "gaps mirror nothing"
    assert maps.specular.max() > 0.5, "the top layer's clear grains mirror"
    # Gaps lie below the grains around them: darker occlusion than the grains' tops.
    gaps, tops = textures.layer < 0, textures.height > 0.6
    assert maps.occlusion[gaps].mean() < maps.occlusion[tops].mean() - 0.1
    # A half space of grains reflects less than a Lambertian surface of their albedo.
    assert np.all((maps.albedo_scale > 0.3) & (maps.albedo_scale < 1.0))


def test_box_mean_wraps_at_the_tiles_edges():
    rng = np.random.default_rng(3)
    values = rng.random((20, 20))
    r = 3
    rolled = sum(
        np.roll(np.roll(values, i, 0), j, 1) for i in range(-r, r + 1) for j in range(-r, r + 1)
    )
    assert np.allclose(material._box_mean_periodic(values, r), rolled / (2 * r + 1) ** 2)


def test_a_flat_grey_lambert_like_sand_keeps_its_albedo_to_within_its_brdf():
    # With no subsurface or transmission terms and flat normals, the equivalent albedo is d'Eon's
    # bi-hemispherical reflectance over the particles' albedo: below 1, above a half.
    preset = Preset().replace(**{"shading.sss": 0.0, "shading.transmission": 0.0})
    flat = (0.0, 0.0, 0.0, 0.0)
    for kd in (0.05, 0.3, 0.9):
        ratio = lambert_equivalent_albedo(preset, np.full(3, kd), flat) / kd
        assert np.all((ratio > 0.5) & (ratio < 1.05)), (kd, ratio)


@pytest.mark.parametrize("kd", [1e-4, 1.0])
@pytest.mark.parametrize(
    "light, eye",
    [
        ((0.0, 0.0, 1.0), (0.0, 0.0, 1.0)),  # both straight up: the azimuth is moot
        ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),  # the sun on the horizon
        ((0.0, 0.0, 1.0), (-1.0, 0.0, 1e-9)),  # a grazing eye
        ((0.6, 0.0, 0.8), (-0.6, 0.0, 0.8)),  # the mirror direction
        ((0.6, 0.0, 0.8), (0.6, 0.0, 0.8)),  # exactly towards the sun
        ((0.0, 0.6, -0.8), (0.0, 0.0, 1.0)),  # the sun below the horizon
    ],
)
def test_the_far_field_has_no_nan_at_hard_directions(kd, light, eye):
    preset = Preset()
    eye = np.array(eye) / np.linalg.norm(eye)
    for moments in ((0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.5, 0.5), (0.2, -0.1, 0.99, 0.99)):
        with np.errstate(all="raise"):
            radiance = far_radiance_per_irradiance(preset, np.full(3, kd), moments, light, eye)
        assert np.all(np.isfinite(radiance)) and np.all(radiance >= 0.0)
        if light[2] < 0:
            assert np.all(radiance == 0.0)


@pytest.mark.parametrize("target", TARGETS)
def test_every_target_names_packs_and_explains_its_maps(red, target):
    preset, _, maps = red
    files = texture_set(preset, maps, target, MapFormats(), "sand")
    assert list(files)[-1] == "README.txt"
    readme = files["README.txt"].decode()
    for name in list(files)[:-1]:
        assert name.startswith("sand_") and name in readme
        assert decode(files[name]).shape[:2] == (SIZE, SIZE)
    assert "glints" in readme and target in readme


def _normal_green(files) -> np.ndarray:
    name = next(n for n in files if n.endswith(("_Normal.png", "_Normal.exr")))
    return decode(files[name])[..., 1].astype(np.float64)


def test_unreal_normals_are_directx_and_the_others_opengl(red):
    preset, _, maps = red
    sets = {t: texture_set(preset, maps, t, MapFormats(), "s") for t in TARGETS}
    gl = _normal_green(sets["gltf"])
    assert np.array_equal(gl, _normal_green(sets["godot"]))
    assert np.array_equal(gl, _normal_green(sets["unity-hdrp"]))
    assert np.abs(gl + _normal_green(sets["unreal"]) - 255.0).max() <= 1.0, "green flipped"
    # OpenGL's +Y is up the image: a grain's upper rim (its normal leaning to +v, which is
    # towards the image's top) is green-bright.
    top_rows = material.image_rows(maps.normal)[..., 1] > 0.5
    assert gl[top_rows].mean() > 200


def test_the_unity_mask_map_and_the_orm_maps_pack_their_channels(red):
    preset, _, maps = red
    mask = decode(texture_set(preset, maps, "unity-hdrp", MapFormats(), "s")["s_MaskMap.png"])
    orm = decode(texture_set(preset, maps, "unreal", MapFormats(), "s")["s_ORM.png"])
    occlusion = np.rint(material.image_rows(maps.occlusion) * 255)
    roughness = np.rint(material.image_rows(maps.roughness) * 255)
    assert np.array_equal(mask[..., 0], np.zeros_like(occlusion)), "metallic 0"
    assert np.array_equal(mask[..., 1], occlusion)
    assert np.all(mask[..., 2] == 255), "detail mask on"
    assert np.array_equal(mask[..., 3], 255 - roughness), "smoothness = 1 − roughness"
    assert np.array_equal(orm[..., 0], occlusion) and np.array_equal(orm[..., 1], roughness)
    assert np.all(orm[..., 2] == 0)


def test_exr_and_16_bit_maps_hold_what_8_bit_rounds(red):
    preset, _, maps = red
    deep = texture_set(preset, maps, "godot", MapFormats(normal="exr", height="exr"), "s")
    normal = decode(deep["s_Normal.exr"])
    assert normal.dtype == np.float32
    # Half floats: 11 significant bits, eight times finer than an 8-bit map's steps.
    exact = material.image_rows(maps.normal) * 0.5 + 0.5
    assert np.abs(normal - exact).max() <= 2.0**-11
    assert np.array_equal(normal, exact.astype(np.float16).astype(np.float32))
    assert "half-float EXR" in deep["README.txt"].decode()
    height = decode(deep["s_Height.exr"])
    assert np.allclose(height, material.image_rows(maps.height), atol=1e-6)
    sixteen = texture_set(preset, maps, "godot", MapFormats(normal="png16"), "s")
    assert decode(sixteen["s_Normal.png"]).dtype == np.uint16
    assert "16-bit PNG" in sixteen["README.txt"].decode()


def test_unknown_formats_and_targets_are_refused_by_name():
    with pytest.raises(ValueError, match="--normal-format 'tiff' is unknown; allowed png8"):
        MapFormats(normal="tiff")
    with pytest.raises(ValueError, match="unknown target 'blender'"):
        BakeSteps(Preset(), SIZE, "x", target="blender")
    with pytest.raises(ValueError, match="apply to the engine targets"):
        BakeSteps(Preset(), SIZE, "x", formats=MapFormats(normal="exr"))


@pytest.mark.gl
def test_bake_target_writes_the_set_and_a_stopped_one_nothing(gl_ctx, tmp_path, capsys):
    status = main(["bake", "black-volcanic", "--size", "64", "--target", "unreal",
                   "--normal-format", "exr", "--out", str(tmp_path / "set")])  # fmt: skip
    assert status == 0
    assert sorted(p.name for p in (tmp_path / "set").iterdir()) == [
        "README.txt",
        "black-volcanic_BaseColor.png",
        "black-volcanic_GlintValue.exr",
        "black-volcanic_Height.png",
        "black-volcanic_Normal.exr",
        "black-volcanic_ORM.png",
    ]
    said = capsys.readouterr()
    assert "(unreal set)" in said.out and said.err == ""
    steps = BakeSteps(Preset(), 256, tmp_path / "stopped", target="godot")
    next(steps)
    steps.close()
    assert not (tmp_path / "stopped").exists()


class _Terminal:
    def __init__(self) -> None:
        self.text = ""

    def isatty(self) -> bool:
        return True

    def write(self, text: str) -> None:
        self.text += text

    def flush(self) -> None:
        pass


def test_the_progress_bar_draws_on_a_terminal_and_stops_on_ctrl_c(capsys):
    terminal = _Terminal()
    run_with_progress(iter([(0.0, "a"), (0.5, "b"), (1.0, "Done")]), terminal)
    assert "50% b" in terminal.text and "100% Done" in terminal.text
    assert terminal.text.endswith("\r"), "the bar is wiped at the end"

    closed = []

    class Interrupted:
        def __iter__(self):
            return self

        def __next__(self):
            raise KeyboardInterrupt

        def close(self):
            closed.append(True)

    with pytest.raises(KeyboardInterrupt):
        run_with_progress(Interrupted(), _Terminal())
    assert closed == [True]
    assert "cancelled: nothing was written" in capsys.readouterr().err


@pytest.mark.gl
def test_the_default_bake_is_unchanged(gl_ctx, tmp_path):
    record = bake(Preset(), SIZE, tmp_path)
    assert record["format"] == "sand-editor-material"
    assert (tmp_path / "height.png").exists() and (tmp_path / "material.json").exists()


_ROOT = "{root}"  # stands for the test's own folder, so an absolute name would land in it
_names = st.one_of(
    st.text(min_size=1, max_size=80),
    st.builds(lambda up, rest: "../" * up + rest, st.integers(1, 4), st.text(max_size=60)),
    st.builds(lambda rest: f"{_ROOT}/{rest}", st.text(max_size=60)),
).filter(lambda name: 1 <= len(name) <= 80 and name.isprintable())


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=_names, target=st.sampled_from(TARGETS))
@example(name="../../ESCAPED_rel", target="unreal")
@example(name=f"{_ROOT}/ESCAPED_abs", target="godot")
@example(name="..", target="gltf")
@example(name="CON", target="unity-hdrp")
@example(name="é" * 80, target="unreal")
def test_a_preset_name_writes_nothing_outside_the_bake_folder(name, target):
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder).resolve()
        out = root / "deep" / "out"
        preset = dataclasses.replace(Preset(), name=name.replace(_ROOT, str(root)))
        record = bake(preset, SIZE, out, backend="reference", target=target)
        made = {path for path in root.rglob("*") if path.is_file()}
        assert made and all(path.parent == out for path in made), sorted(map(str, made))
        assert sorted(path.name for path in made) == sorted(record["files"])
        assert "README.txt" in record["files"]
