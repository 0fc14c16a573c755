"""The wind ripples (shaders/sand_far.glsl): made where they are seen, so they never repeat, and
filtered analytically, so that far away they neither alias into moiré nor change the light."""
# The probe draws with the renderer's filtering along each pixel's footprint.

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.bench.probe import MaterialProbe
from sand_editor.colour import luminance
from sand_editor.preset import Preset
from sand_editor.render import far_brdf
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.material import SandMaterial
from sand_editor.resources import bundled_preset

pytestmark = pytest.mark.gl

STRONG_RIPPLES = {"shading.ripple_strength": 0.3, "shading.detail_strength": 0.0}
LOW_SUN = np.array([0.25, 0.3, -0.92])  # 17° up: the ripples' shading at its strongest
SMALL = (160, 90)
SUPERSAMPLE = 8


@pytest.fixture(scope="module")
def material(gl_ctx):
    material = SandMaterial(gl_ctx, 64)
    material.update(Preset.load(bundled_preset("paper-default")).replace(**STRONG_RIPPLES))
    yield material
    material.release()


def _far_frame(material, size, distance, pitch=15.0, target=(0.0, 0.0), filtered=True):
    probe = MaterialProbe(material, *size)
    try:
        probe.filter_ripples = filtered
        probe.sun_direction = LOW_SUN
        camera = camera_at_distance(distance, pitch, size[0] / size[1], target_xz=target)
        image, _ = probe.render(camera, "far")
    finally:
        probe.release()
    assert np.isfinite(image).all()
    return luminance(image)


def test_the_ripples_never_repeat(material, gl_clean):
    """Two views a metre apart (the period the ripples once repeated at) and a tile of the
    grains apart differ: nothing lays the ripples down as a tile."""
    here = _far_frame(material, SMALL, 2.0, pitch=90.0)
    for shift in (1.0, 8.0):
        there = _far_frame(material, SMALL, 2.0, pitch=90.0, target=(shift, 0.0))
        change = np.abs(there - here).mean() / here.mean()
        assert change > 0.05, f"a view {shift} m along matches: {change:.3f}"


def _against_truth(material, distance) -> tuple[float, float]:
    """The frame's ground mean over its 8×8 supersampled truth's (its ripples unfiltered),
    and their relative RMS."""
    small = _far_frame(material, SMALL, distance)
    large = (SMALL[0] * SUPERSAMPLE, SMALL[1] * SUPERSAMPLE)
    big = _far_frame(material, large, distance, filtered=False)
    truth = big.reshape(SMALL[1], SUPERSAMPLE, SMALL[0], SUPERSAMPLE).mean(axis=(1, 3))
    ground = slice(SMALL[1] * 2 // 5, None)  # below the horizon, which is at 15° up
    small, truth = small[ground], truth[ground]
    error = float(np.sqrt(np.mean((small - truth) ** 2)) / truth.mean())
    return float(small.mean() / truth.mean()), error


# The black sand's light is mostly its glints: its frames stray farther per pixel (0.12 and 0.17;
# at 30 m, 0.096 from a 24×24 truth, where the 8×8 truth itself is 0.065 from it).
@pytest.mark.parametrize(
    ("name", "most"),
    [
        ("paper-default", 0.06),
        ("black-volcanic", 0.2),
        ("pale-quartz", 0.06),
        ("red-desert", 0.06),
    ],  # fmt: skip
)
@pytest.mark.parametrize("distance", [30.0, 100.0])
def test_far_ripples_match_their_supersampled_truth(gl_ctx, gl_clean, name, most, distance):
    """Every shipped sand's ripples, a fraction of a pixel wide, are drawn as the 8×8
    supersampled frame (its ripples unfiltered) shows them under a low sun ahead: the same
    light within 4.5 % and no moiré (relative RMS under 0.06, the black sand's 0.2). With the
    glints shaded on the ripples' mean slope alone, the black sand's light was 28 % short (RMS
    0.38), and paper-default's 6 % (RMS 0.10)."""
    material = SandMaterial(gl_ctx, 64)
    try:
        material.update(Preset.load(bundled_preset(name)).replace(**{"shading.detail_strength": 0}))
        ratio, error = _against_truth(material, distance)
    finally:
        material.release()
    assert ratio == pytest.approx(1.0, abs=0.045)
    assert error < most, f"relative RMS {error:.3f} against the supersampled frame"


def test_strong_ripples_do_not_alias_far_away(material, gl_clean):
    """Ripples of strength 0.3 at 30 m: relative RMS 0.16 against the supersampled frame (0.80
    with the ripples unfiltered, where moiré covers the ground)."""
    _, error = _against_truth(material, 30.0)
    assert error < 0.25, f"relative RMS {error:.3f} against the supersampled frame"


def test_the_shaders_mean_square_of_a_ripples_slope_is_the_profiles():
    """The unresolved ripples' deviation rests on the profile's mean square of slope: the
    shaders' fit (far_brdf.RIPPLE_MEAN_SQUARE_FIT) within 0.5 % of the integral, ½ for a sine."""
    sharp = np.linspace(0.0, 1.0, 41)
    exact = np.array([far_brdf.ripple_mean_square(s) for s in sharp])
    assert exact[0] == pytest.approx(0.5, abs=1e-9)
    assert np.abs(far_brdf.ripple_mean_square_fit(sharp) / exact - 1.0).max() < 0.005


@pytest.mark.parametrize("deviation", [0.1, 0.2, 0.3])
def test_two_tilts_hold_a_ripples_light_where_its_mean_slope_does_not(deviation):
    """Under a sun along the ripples (5° to 70° up), the mean of the clamped cosine over a sine
    ripple of slope deviation up to 0.3: two tilts either side of the mean hold it within 8 %
    (within 6 % from 10° up), the mean slope alone misses it by up to half."""
    phase = 2.0 * np.pi * np.arange(4096) / 4096
    slopes = deviation * np.sqrt(2.0) * np.cos(phase)
    worst_tilts = worst_flat = 0.0
    for elevation in np.radians([5.0, 10.0, 17.0, 30.0, 45.0, 70.0]):
        ripple = np.maximum(0.0, np.sin(elevation + np.arctan(slopes))).mean()
        tilts = np.mean(
            [max(0.0, np.sin(elevation + np.arctan(t))) for t in (-deviation, deviation)]
        )
        worst_tilts = max(worst_tilts, abs(tilts / ripple - 1.0))
        worst_flat = max(worst_flat, abs(np.sin(elevation) / ripple - 1.0))
        if elevation >= np.radians(10.0):
            assert tilts == pytest.approx(ripple, rel=0.06)
    assert worst_tilts < 0.08 and worst_flat > 2.0 * worst_tilts, (worst_tilts, worst_flat)


@pytest.mark.parametrize(
    ("strength", "distance", "most", "light"),
    [
        (None, 30.0, 0.045, 0.02),
        (None, 100.0, 0.045, 0.02),
        (0.3, 30.0, 0.135, 0.06),
        (0.3, 100.0, 0.145, 0.06),
    ],
)
def test_ripples_below_the_pixel_keep_their_light(gl_clean, strength, distance, most, light):
    """Far away the ripples are a fraction of a pixel, but their slopes still turn the sand to
    and from the sun: with their deviation handed to the light, the frame (bench depth's view:
    16:30, pitch 15°) is within FLIP 0.045 of the same view 8×8 supersampled with its ripples
    unfiltered at 30 and 100 m for paper-default (0.036 and 0.037; 0.067 and 0.062 shading the
    ripples' mean slope alone), its ground's light within 2 %. Strong ripples (0.3): FLIP 0.121
    and 0.136, light 4 % and 5 % short; their deviation capped at a slope of 0.3, as it was,
    0.157 and 0.142, and 11 % and 10 % too bright."""
    from sand_editor.bench.depth import SIZE, Views, flip_error
    from sand_editor.colour import srgb_to_linear

    views = Views(256)
    try:
        if strength is not None:
            preset = Preset.load(bundled_preset("paper-default"))
            views.material.update(preset.replace(**{"shading.ripple_strength": strength}))
        frame = views.frame(distance, SIZE)[0][..., :3] / 255.0
        truth = views.truth(distance)[..., :3]
    finally:
        views.release()
    assert np.isfinite(frame).all()
    error = flip_error(truth, frame)
    assert error <= most, f"FLIP {error:.3f} at {distance} m"
    ground = slice(SIZE[1] // 2, None)
    ratio = srgb_to_linear(frame[ground]).mean() / srgb_to_linear(truth[ground]).mean()
    assert ratio == pytest.approx(1.0, abs=light), f"the ground's light {ratio:.3f} of the truth's"
