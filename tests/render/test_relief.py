"""Grain relief up close: each eye sees the grains at their depth (parallax), grains shade the
gaps along a low sun, and none of it reaches the frame where grains are a few pixels or less."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.preset import Preset
from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.resources import bundled_preset
from tests.render.test_renderer import grain_detail, grain_detail_correlations, scene_hdr

pytestmark = pytest.mark.gl

W, H = 320, 180
IPD_M = 0.063
BLOCK = 10


@pytest.fixture(scope="module")
def renderer(gl_ctx):
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    material = SandMaterial(gl_ctx, texture_size=512)
    # Without ripples: the grains' own relief is what is measured, not where a ripple faces.
    flat = {"shading.ripple_strength": 0.0, "shading.detail_strength": 0.0}
    material.update(Preset.load(bundled_preset("paper-default")).replace(**flat))
    r = SandRenderer(gl_ctx)
    r.set_material(material)
    yield r
    r.relief = True
    r.release()
    material.release()


def _camera(renderer, distance, pitch):
    terrain = renderer.terrain
    return camera_at_distance(distance, pitch, W / H, lambda x, z: float(terrain.height(x, z)))


def _draw(renderer, camera, hours, relief, mode="close"):
    renderer.relief = relief
    image = renderer.render_to_array(W, H, FrameRequest(camera, sky_at(hours), mode))
    return image, scene_hdr(renderer)[::-1, :, :3]  # rows top-down, as the image's


def _eye(camera: Camera, side: float) -> Camera:
    """The camera moved sideways by ``side`` metres along its own right."""
    right = camera.view[0, :3].astype(np.float64)
    view = camera.view.astype(np.float64).copy()
    view[0, 3] -= side  # the world moves left in view space as the eye moves right
    return Camera(view=view, projection=camera.projection, eye=camera.eye + side * right)


def _disparity(left: np.ndarray, right: np.ndarray, reach: int = 60) -> int:
    """The horizontal shift (px) that best lays the right eye's central band on the left's."""
    rows = slice(H // 2, H // 2 + 40)
    a = left[rows].astype(np.float64).mean(axis=2)
    b = right[rows].astype(np.float64).mean(axis=2)
    core = slice(reach, W - reach)
    errors = [np.mean((a[:, core] - b[:, reach + s : W - reach + s]) ** 2)
              for s in range(-reach, reach + 1)]  # fmt: skip
    return int(np.argmin(errors)) - reach


def test_each_eye_sees_the_grains_deeper_than_the_flat_plane(renderer, gl_clean):
    # At 1 cm a grain's depth is a tenth of the distance: a tenth less disparity. Two eyes a
    # thirtieth of a person's apart keep the shift within the frame.
    camera = _camera(renderer, 0.01, 60.0)
    eyes = [_eye(camera, side) for side in (-IPD_M / 60, IPD_M / 60)]
    flat = [_draw(renderer, eye, 12.0, False)[0] for eye in eyes]
    deep = [_draw(renderer, eye, 12.0, True)[0] for eye in eyes]
    flat_shift, deep_shift = _disparity(*flat), _disparity(*deep)
    # Farther points have less disparity between two parallel eyes: the grains lie below the
    # plane, so the relief's disparity is the smaller.
    assert flat_shift != 0
    assert abs(deep_shift) < abs(flat_shift) - 1, (flat_shift, deep_shift)


def test_a_low_sun_leaves_the_gaps_between_grains_in_shadow(renderer, gl_clean):
    camera = _camera(renderer, 0.05, 60.0)
    _, flat = _draw(renderer, camera, 18.0, False)
    _, deep = _draw(renderer, camera, 18.0, True)
    ground = slice(H // 2, H)
    flat_lum, deep_lum = flat[ground].mean(axis=2), deep[ground].mean(axis=2)
    assert np.isfinite(deep).all()
    # Percentiles, not the mean: a few sparkles carry much of the mean and move with parallax.
    # The darker quarter of the ground grows darker, and so does the middle of it ...
    assert np.percentile(deep_lum, 25) < 0.92 * np.percentile(flat_lum, 25)  # measured 0.87
    assert np.median(deep_lum) < 0.96 * np.median(flat_lum)  # measured 0.92
    # ... while the noon sun, from above, leaves the light as it was.
    _, flat_noon = _draw(renderer, camera, 12.0, False)
    _, deep_noon = _draw(renderer, camera, 12.0, True)
    noon = np.median(deep_noon[ground].mean(axis=2)) / np.median(flat_noon[ground].mean(axis=2))
    assert noon > 0.97  # measured 1.03


@pytest.mark.parametrize("distance", [3.0, 30.0])
def test_where_grains_are_a_few_pixels_the_relief_leaves_only_its_mean_shadow(
    renderer, gl_clean, distance
):
    """No grain of the relief is drawn there: the frame with relief is the flat frame seen at
    the grains' mean depth (its grains shifted, not reshaped), dimmed smoothly by their mean
    shadowing of the sun, never brightened."""
    camera = _camera(renderer, distance, 35.0)
    _, flat = _draw(renderer, camera, 16.5, False, "full")
    _, deep = _draw(renderer, camera, 16.5, True, "full")
    # Blocks of BLOCK² pixels: many grains each, so a shift of a grain or so leaves their means.
    rows, cols = (H // 2) // BLOCK, W // BLOCK

    def blocks(image):
        ground = image[H // 2 :][: rows * BLOCK, : cols * BLOCK].sum(axis=-1).astype(np.float64)
        return ground.reshape(rows, BLOCK, cols, BLOCK).mean(axis=(1, 3))

    ratio = blocks(deep) / np.maximum(blocks(flat), 1e-6)
    assert ratio.max() <= 1.005, ratio.max()
    assert ratio.mean() < 0.97, ratio.mean()  # a 25° sun: the grains shade one another
    # Smooth from block to block (drawn relief would change from grain to grain).
    assert np.abs(np.diff(ratio, axis=1)).max() < 0.03


@pytest.mark.parametrize("name", ["paper-default", "red-desert"])
def test_the_far_light_is_the_mean_of_the_drawn_shadows(gl_ctx, gl_clean, name):
    """At a low sun the relief up close (grain cells ~70 px) shades much of the ground; the far
    range, lit by the grains' mean shadowing, holds the same light (without it, 14 % more)."""
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    material = SandMaterial(gl_ctx, texture_size=512)
    flat = {"shading.ripple_strength": 0.0, "shading.detail_strength": 0.0}
    material.update(Preset.load(bundled_preset(name)).replace(**flat))
    r = SandRenderer(gl_ctx)
    r.set_material(material)
    try:
        terrain = r.terrain
        camera = camera_at_distance(
            0.03, 35.0, W / H, lambda x, z: float(terrain.height(x, z)), heading_deg=180.0
        )
        means = {}
        for mode in ("close", "far"):
            r.render_to_array(W, H, FrameRequest(camera, sky_at(17.75), mode))
            means[mode] = float(scene_hdr(r)[: H // 2, :, :3].mean())  # rows bottom-up
        assert means["close"] == pytest.approx(means["far"], rel=0.07), means
    finally:
        r.release()
        material.release()


@pytest.mark.parametrize("pitch", [1.0, 5.0, 90.0])
@pytest.mark.parametrize("hours", [6.05, 18.0, 12.0])
def test_grazing_views_and_suns_give_finite_relief(renderer, gl_clean, pitch, hours):
    _, hdr = _draw(renderer, _camera(renderer, 0.002, pitch), hours, True, "full")
    assert np.isfinite(hdr).all()


def test_grains_stay_where_they_are_seen_as_the_relief_fades(renderer, gl_clean):
    """Where the relief fades out of a pixel, the pixel still shows the grains at their mean
    depth: the frame matches the same view drawn 8× larger (relief at full weight there) and
    averaged, at no shift, rather than half a pixel towards the eye."""
    camera = _camera(renderer, 1.0, 15.0)
    renderer.relief = True
    k = 8
    at = grain_detail_correlations(renderer, camera, sky_at(16.5), (W, H), (-k // 2, 0, k // 2), k)
    # Measured 0.48 at no shift, 0.29 and 0.31 half a pixel either way; grains drawn at their
    # tops where the relief fades out gave 0.20 here and 0.44 half a pixel up.
    assert at[0] > 0.4, at
    assert at[0] > max(at[-k // 2], at[k // 2]) + 0.1, at


def test_a_grazing_eye_sees_grains_not_fins(renderer, gl_clean):
    """Along a grazing ray a height field shows its steep sides as each top's texel smeared down
    the wall, stripes along the view; the relief fades as the eye's cosine falls to 0.3 and
    below, so the ground changes from column to column about as much as flat grains do."""
    camera = _camera(renderer, 0.05, 4.0)

    def across_over_along(relief: bool) -> float:
        lum = _draw(renderer, camera, 12.0, relief)[0][H // 2 :].astype(np.float64).mean(axis=2)
        lum -= lum.mean(axis=1, keepdims=True)
        along = np.abs(np.diff(lum, axis=0)).mean()
        return float(np.abs(np.diff(lum, axis=1)).mean() / along)

    flat, deep = across_over_along(False), across_over_along(True)
    # Measured 0.265 flat, 0.261 with relief; 0.377 before the relief faded at grazing eyes.
    assert deep < 1.2 * flat, (flat, deep)


@pytest.mark.parametrize(("strength", "least"), [(0.1, 0.85), (0.3, 0.6)])
def test_ripples_turn_the_grains_light_not_where_they_lie(
    gl_ctx, renderer, gl_clean, strength, least
):
    """The ripples are a normal on the surface, not a shape: the relief's ray is marched in the
    surface's own frame, so the grains up close lie where they lie without ripples and only
    their light changes. Marched in the ripples' frame, the ray's offset along the surface
    turned with their slope from pixel to pixel: the grains slid by pixels under ripples of
    0.1 and were stretched into fins down the screen about a crest."""
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    camera = _camera(renderer, 0.05, 35.0)
    flat_light = _draw(renderer, camera, 12.0, True)[1]
    cap = 1.5 * float(np.median(flat_light[H // 2 :]))
    flat = grain_detail(flat_light, cap)
    material = SandMaterial(gl_ctx, texture_size=512)
    rippled = SandRenderer(gl_ctx)
    try:
        ripples = {"shading.ripple_strength": strength, "shading.detail_strength": 0.0}
        material.update(Preset.load(bundled_preset("paper-default")).replace(**ripples))
        rippled.set_material(material)
        detail = grain_detail(_draw(rippled, camera, 12.0, True)[1], cap)
    finally:
        rippled.release()
        material.release()
    correlation = float(np.corrcoef(flat, detail)[0, 1])
    # Measured 0.946 (0.1) and 0.774 (0.3); marched in the ripples' frame, 0.07 and −0.04.
    assert correlation > least, correlation


def test_a_grains_side_shows_no_stair_steps(renderer, gl_clean):
    """A grain's side is a wall in the height field: the ray's crossing taken between two of its
    steps alone landed on either side of it from one row to the next, stripes along the view
    (rows change more sharply than columns: second over first differences). The step that
    passes below is halved before the crossing is taken."""
    width, height = 2 * W, 2 * H  # the same aspect as _camera's
    camera = _camera(renderer, 0.03, 15.0)
    renderer.relief = True
    for hours in (16.5, 7.5):
        request = FrameRequest(camera, sky_at(hours), "close")
        lum = renderer.render_to_array(width, height, request)[height // 2 :].astype(np.float64)
        along, across = (_sharpness(lum.mean(axis=2), axis) for axis in (0, 1))
        # Measured 1.15 (16:30) and 1.19 (07:30); 1.30 and 1.32 between two steps alone.
        assert along / across < 1.24, (hours, along, across)


def _sharpness(lum: np.ndarray, axis: int) -> float:
    """Mean second difference over mean first difference along ``axis``."""
    return float(np.abs(np.diff(lum, 2, axis=axis)).mean() / np.abs(np.diff(lum, axis=axis)).mean())
