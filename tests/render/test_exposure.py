"""Exposure that adapts as an eye does: to the light, part of the way to the scene, over time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.render.exposure import (
    ADAPT_SECONDS,
    MAX_SCENE_FACTOR,
    MID_GREY,
    SCENE_ADAPTATION,
    EyeAdaptation,
    light_exposure,
    light_luminance,
    metered_exposure,
)
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import parse_time, sky_at

NOON = sky_at(parse_time("12:00"))


def grey(sky) -> float:
    return MID_GREY / math.pi * light_luminance(sky)


def test_a_mid_grey_scene_gets_the_lights_exposure():
    assert metered_exposure(NOON, grey(NOON)) == pytest.approx(light_exposure(NOON))


def test_dark_and_bright_scenes_move_it_only_part_of_the_way():
    dark = metered_exposure(NOON, 0.1 * grey(NOON))
    bright = metered_exposure(NOON, 4.0 * grey(NOON))
    base = light_exposure(NOON)
    assert dark / base == pytest.approx(10.0**SCENE_ADAPTATION)  # not 10: black stays dark
    assert bright / base == pytest.approx(4.0**-SCENE_ADAPTATION)  # not ¼: white stays white
    assert metered_exposure(NOON, 1e-12) / base == pytest.approx(MAX_SCENE_FACTOR)


@pytest.mark.parametrize("scene", [0.0, -1.0, float("nan"), float("inf")])
def test_a_scene_that_cannot_be_metered_keeps_the_lights_exposure(scene):
    assert metered_exposure(NOON, scene) == light_exposure(NOON)


@pytest.mark.parametrize("hours", [0.0, 3.0, 12.0, 20.5])
def test_exposure_is_finite_and_positive_day_and_night(hours):
    sky = sky_at(hours)
    for scene in (0.0, 1e-9, grey(sky), 1e6):
        value = metered_exposure(sky, scene)
        assert math.isfinite(value) and value > 0


def test_night_is_exposed_more_than_day_but_stays_darker():
    night = sky_at(parse_time("01:00"))
    assert light_exposure(night) > light_exposure(NOON)
    # Partial adaptation: the night's grey sand shows darker than the day's.
    assert light_exposure(night) * grey(night) < light_exposure(NOON) * grey(NOON)


def test_the_eye_adapts_in_about_its_time_constant():
    eye = EyeAdaptation()
    assert eye.step(1.0, 0.016) == 1.0  # the first frame jumps
    after = eye.step(math.e, ADAPT_SECONDS)
    assert math.log(after) == pytest.approx(1.0 - math.exp(-1.0))
    for _ in range(200):
        eye.step(math.e, 0.05)
    assert eye.exposure == pytest.approx(math.e, rel=1e-6)
    assert eye.step(5.0, None) == 5.0  # no time given: jump
    assert eye.step(7.0, -1.0) == 7.0  # a clock that went back: jump
    assert eye.step(2.0, float("nan")) == 2.0


@pytest.mark.gl
def test_black_sand_is_exposed_more_than_white_and_a_fixed_exposure_is_kept(gl_ctx):
    from sand_editor.preset import Preset
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer
    from sand_editor.resources import bundled_preset

    material = SandMaterial(gl_ctx, 64)
    renderer = SandRenderer(gl_ctx)
    target = gl_ctx.framebuffer([gl_ctx.texture((64, 36), 4)])
    camera = camera_at_distance(3.0, 35.0, 64 / 36)
    try:
        exposures = {}
        for name in ("black-volcanic", "pale-quartz"):
            material.update(Preset.load(bundled_preset(name)))
            renderer.set_material(material)
            renderer.exposure.adaptation.reset()
            exposures[name] = renderer.render(target, FrameRequest(camera, NOON))["exposure"]
        assert exposures["black-volcanic"] > 1.2 * exposures["pale-quartz"]
        assert exposures["black-volcanic"] < 4.0 * exposures["pale-quartz"]
        assert (
            renderer.render(target, FrameRequest(camera, NOON, exposure=0.75))["exposure"] == 0.75
        )
        # Frames of a still view, one after another: the metered exposure is the same.
        again = [renderer.render(target, FrameRequest(camera, NOON))["exposure"] for _ in range(2)]
        assert again[0] == pytest.approx(again[1])
        # A view that runs on adapts: the first frame after the change keeps most of the old.
        renderer.exposure.adapt_over_time = True
        renderer.render(target, FrameRequest(camera, NOON, exposure=None))
        renderer.exposure.adaptation.exposure = 10 * again[0]
        adapted = renderer.render(target, FrameRequest(camera, NOON))["exposure"]
        assert again[0] < adapted < 10 * again[0]
        renderer.exposure.adapt_over_time = False
        night = renderer.render(target, FrameRequest(camera, sky_at(parse_time("02:00"))))[
            "exposure"
        ]
        assert np.isfinite(night) and night > 0
    finally:
        target.release()
        renderer.release()
        material.release()
