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


# The black sand's light is mostly its glints: its frames stray farther per pixel (0.072 and
# 0.149; its 8×8 truth is itself 0.065 from a 24×24 one at 30 m).
@pytest.mark.parametrize(
    ("name", "most"),
    [
        ("paper-default", 0.06),
        ("black-volcanic", 0.16),
        ("pale-quartz", 0.04),
        ("red-desert", 0.04),
    ],  # fmt: skip
)
@pytest.mark.parametrize("distance", [30.0, 100.0])
def test_far_ripples_match_their_supersampled_truth(gl_ctx, gl_clean, name, most, distance):
    """Every shipped sand's ripples, a fraction of a pixel wide, are drawn as the 8×8
    supersampled frame (its ripples unfiltered) shows them under a low sun ahead: the same
    light within 1.5 % (all four within 0.6 %) and no moiré (relative RMS under 0.06, the black
    sand's 0.16). With the glints at two tilts either side of the ripples' mean slope and the
    sky at the mean slope alone, the black sand's light was 3.5 % short (RMS 0.117 at 30 m),
    red-desert's 3.9 % too bright; with the glints at the mean slope alone, the black sand's
    light was 28 % short (RMS 0.38)."""
    material = SandMaterial(gl_ctx, 64)
    try:
        material.update(Preset.load(bundled_preset(name)).replace(**{"shading.detail_strength": 0}))
        ratio, error = _against_truth(material, distance)
    finally:
        material.release()
    assert ratio == pytest.approx(1.0, abs=0.015)
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


def _clamped_cosine(slopes, elevation):
    """The cosine of a sun along the ripples' axis, ``elevation`` up, on the slopes' normals."""
    return np.maximum(0.0, np.sin(elevation + np.arctan(slopes)))


@pytest.mark.parametrize("sharp", [far_brdf.RIPPLE_SHARPNESS, far_brdf.RIPPLE_STEEP_SHARPNESS])
@pytest.mark.parametrize("strength", [0.053, 0.3, 1.0])
def test_three_thirds_hold_a_ripples_light_where_two_tilts_do_not(sharp, strength):
    """Under a sun along the ripples, from either side, 5° to 70° up, the mean of the clamped
    cosine over the unfiltered profile (paper-default's strength, 0.3 and the slider's top, on
    gentle and steep ground): the three thirds' mean angles (far_brdf.ripple_tilt_slopes) hold
    it within 4–9 % at every sun on gentle ground, 6–22 % on steep; two tilts either side of
    the mean, of the same deviation, miss it by up to 22–50 % and 26–89 %."""
    steepest = far_brdf.RIPPLE_SLOPE_GAIN * strength
    slopes = steepest * far_brdf.ripple_slopes(sharp)
    deviation = float(np.sqrt(np.mean(slopes**2)))
    thirds = far_brdf.ripple_tilt_slopes(steepest, sharp)
    two = np.array([deviation, -deviation])
    worst = {}
    for name, tilts in (("thirds", thirds), ("two", two)):
        worst[name] = max(
            abs(_clamped_cosine(tilts, e).mean() / _clamped_cosine(slopes, e).mean() - 1.0)
            for e in np.radians([5.0, 10.0, 17.0, 30.0, 45.0, 70.0, 110.0, 135.0, 150.0, 175.0])
        )
    assert worst["thirds"] < (0.1 if sharp == far_brdf.RIPPLE_SHARPNESS else 0.25), worst
    assert worst["thirds"] < 0.5 * worst["two"], worst


def test_the_shaders_three_thirds_are_the_profiles():
    """The shaders take each third's mean angle from quadratic fits of four of its quantiles
    (far_brdf.ripple_quantile_fit): within 0.04 radians of the angles themselves, for steepest
    slopes of 0.05 to 12 over the shipped asymmetries."""
    for sharp in np.linspace(far_brdf.RIPPLE_SHARPNESS, far_brdf.RIPPLE_STEEP_SHARPNESS, 9):
        for steepest in (0.05, 0.3, 1.0, 2.0, 4.0, 8.0, 12.0):
            exact = np.arctan(far_brdf.ripple_tilt_slopes(steepest, sharp))
            fitted = np.arctan(far_brdf.ripple_tilt_slopes_fit(steepest, sharp))
            assert np.abs(fitted - exact).max() < 0.04, (sharp, steepest, exact, fitted)
            assert np.all(np.diff(exact) > 0.0)


@pytest.mark.parametrize(
    ("strength", "distance", "most", "light"),
    [
        (None, 30.0, 0.03, 0.015),
        (None, 100.0, 0.03, 0.015),
        (0.3, 30.0, 0.06, 0.025),
        (0.3, 100.0, 0.06, 0.025),
        (1.0, 30.0, 0.1, 0.06),
    ],
)
def test_ripples_below_the_pixel_keep_their_light(gl_clean, strength, distance, most, light):
    """Far away the ripples are a fraction of a pixel, but their slopes still turn the sand to
    and from the sun and the sky and lengthen and shorten the grains' shadows: with them handed
    to the light, the frame (bench depth's view: 16:30, pitch 15°) is within FLIP 0.03 of the
    same view 8×8 supersampled with its ripples unfiltered at 30 and 100 m for paper-default
    (0.020 and 0.018), its ground's light within 1.5 %. Strong ripples: 0.3, FLIP 0.040 and
    0.032, light within 1.2 %; 1 (slopes to 8), FLIP 0.079, light 4 % over. At two tilts either
    side of the mean slope, with the sky and the shadows at the mean slope alone, as they were:
    paper-default 0.036 and 0.037; ripples 0.3, 0.121 and 0.136, 4 % and 5 % short; ripples 1,
    0.160, 9 % over."""
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
