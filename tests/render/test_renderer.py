from __future__ import annotations

import numpy as np
import pytest

from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.modes import MODES
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at

pytestmark = pytest.mark.gl

W, H = 128, 96
ASPECT = W / H


def scene_hdr(renderer) -> np.ndarray:
    texture = renderer.post.scene_texture
    data = np.frombuffer(texture.read(), dtype=np.float16).astype(np.float32)
    return data.reshape(texture.size[1], texture.size[0], 4)


def grain_detail_correlations(
    renderer, camera, sky, size: tuple[int, int], shifts=(0,), k: int = 8
) -> dict[int, float]:
    """How well the grains of the close range's frame of ``size`` match those of the same view
    drawn k× larger and averaged k×k, moved down by each of ``shifts`` of the larger frame's
    pixels: the correlation over the ground of the luminance less its 5×5 box mean (the light's
    slow change), sparkles capped at 1.5× the median (a few bright sub-pixels that no single
    sample places)."""
    width, height = size
    frames = []
    for scale in (1, k):
        renderer.render_to_array(width * scale, height * scale, FrameRequest(camera, sky, "close"))
        frames.append(scene_hdr(renderer)[::-1, :, :3].astype(np.float64))
    small, big = frames
    cap = 1.5 * float(np.median(small[height // 2 :]))
    big = np.minimum(big, cap)  # each sample's sparkle capped before they are averaged
    ours = grain_detail(small, cap)
    correlation = {}
    for shift in shifts:
        shifted = np.roll(big, shift, axis=0).reshape(height, k, width, k, 3).mean(axis=(1, 3))
        correlation[shift] = float(np.corrcoef(ours, grain_detail(shifted, cap))[0, 1])
    return correlation


def grain_detail(image: np.ndarray, cap: float) -> np.ndarray:
    """The ground's (lower half's, 8 pixels in from its edges) luminance less its 5×5 box mean
    (the light's slow change), each pixel's light capped at ``cap``: the grains' detail."""
    height = image.shape[0]
    lum = np.minimum(image, cap)[height // 2 + 8 : -8, 8:-8].mean(axis=-1)
    padded = np.pad(lum, 2, mode="edge")
    rows, cols = lum.shape
    box = sum(padded[i : i + rows, j : j + cols] for i in range(5) for j in range(5))
    return (lum - box / 25.0).ravel()


def ground_camera(renderer, distance=4.0, pitch=30.0, heading=0.0):
    return camera_at_distance(distance, pitch, ASPECT, renderer.terrain.height, heading_deg=heading)


@pytest.mark.parametrize("mode", MODES)
def test_every_mode_renders_finite_pixels(sand_renderer, gl_clean, mode):
    image = sand_renderer.render_to_array(
        W, H, FrameRequest(ground_camera(sand_renderer), sky_at(10.0), mode)
    )
    assert image.shape == (H, W, 3) and image.dtype == np.uint8
    assert np.isfinite(scene_hdr(sand_renderer)).all()
    assert image.std() > 0 or mode == "blend", "a frame of one flat colour"


def test_a_debug_mode_differs_from_full(sand_renderer, gl_clean):
    camera, sky = ground_camera(sand_renderer), sky_at(10.0)
    full = sand_renderer.render_to_array(W, H, FrameRequest(camera, sky, "full")).astype(int)
    normals = sand_renderer.render_to_array(W, H, FrameRequest(camera, sky, "normals")).astype(int)
    assert np.abs(full - normals).mean() > 20
    # Debug views are raw values: micro normals of a mostly upward surface are mostly green.
    assert normals[..., 1].mean() > normals[..., 0].mean() + 40


def test_the_sky_is_brighter_at_noon_than_at_midnight(sand_renderer, gl_clean):
    looking_up = Camera.look_at((0.0, 10.0, 0.0), (0.0, 20.0, -10.0), aspect=ASPECT)
    noon = sand_renderer.render_to_array(W, H, FrameRequest(looking_up, sky_at(12.0), "full"))
    midnight = sand_renderer.render_to_array(W, H, FrameRequest(looking_up, sky_at(0.0), "full"))
    assert noon.mean() > 2 * midnight.mean()
    assert noon[..., 2].mean() > noon[..., 0].mean(), "a blue day sky"


def brightest_pixel(image: np.ndarray) -> np.ndarray:
    luminance = image.astype(np.float32) @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    row, column = np.unravel_index(np.argmax(luminance), luminance.shape)
    return np.array([column, row])


def projected_pixel(camera: Camera, direction) -> np.ndarray:
    view = camera.view_relative_to(camera.eye)
    clip = camera.projection.astype(np.float64) @ view @ [*direction, 0.0]
    ndc = clip[:2] / clip[3]
    return np.array([(ndc[0] + 1) / 2 * W, (1 - ndc[1]) / 2 * H])


def test_the_sun_moves_across_the_image_with_the_clock(sand_renderer, gl_clean):
    morning, later = sky_at(7.0), sky_at(7.75)
    middle = morning.sun_direction + later.sun_direction
    eye = np.array([0.0, sand_renderer.terrain.height(0.0, 0.0) + 20.0, 0.0])
    camera = Camera.look_at(eye, eye + middle, fov_y_deg=70.0, aspect=ASPECT)
    found = []
    for sky in (morning, later):
        image = sand_renderer.render_to_array(W, H, FrameRequest(camera, sky, "full"))
        where = brightest_pixel(image)
        assert np.abs(where - projected_pixel(camera, sky.sun_direction)).max() <= 3
        found.append(where)
    assert np.abs(found[0] - found[1]).max() > 10


@pytest.mark.parametrize("distance, pitch", [(1e-3, 30.0), (1e-3, 1.0), (2.0, 1.0), (1000.0, 20.0)])
def test_extreme_views_render_finite_images(sand_renderer, gl_clean, distance, pitch):
    camera = ground_camera(sand_renderer, distance, pitch, heading=120.0)
    image = sand_renderer.render_to_array(W, H, FrameRequest(camera, sky_at(15.0), "full"))
    hdr = scene_hdr(sand_renderer)
    assert np.isfinite(hdr).all()
    # The lower half of the frame looks at the sand, not through it.
    assert hdr[: H // 2, :, :3].mean() > 0
    assert image.std() > 0


def test_the_sphere_appears_on_request(sand_renderer, gl_clean):
    camera, sky = ground_camera(sand_renderer, 3.0, 25.0), sky_at(10.0)
    without = sand_renderer.render_to_array(
        W, H, FrameRequest(camera, sky, "normals", show_sphere=False)
    )
    with_sphere = sand_renderer.render_to_array(
        W, H, FrameRequest(camera, sky, "normals", show_sphere=True)
    )
    changed = np.abs(without.astype(int) - with_sphere.astype(int)).max(axis=-1) > 30
    assert 0.01 < changed.mean() < 0.5


def test_render_draws_only_into_its_viewport_and_restores_the_bound_framebuffer(
    sand_renderer, gl_clean
):
    ctx = gl_clean
    texture = ctx.texture((W, H), 4)
    target = ctx.framebuffer([texture])
    other = ctx.framebuffer([ctx.texture((8, 8), 4)])
    try:
        target.clear(1.0, 0.0, 1.0, 1.0)
        other.use()
        viewport = (W // 2, 0, W // 2, H // 2)
        times = sand_renderer.render(
            target, FrameRequest(ground_camera(sand_renderer), sky_at(10.0), viewport=viewport)
        )
        assert ctx.fbo == other
        assert times["exposure"] > 0
        image = np.frombuffer(target.read(components=3), dtype=np.uint8).reshape(H, W, 3)
        magenta = np.all(image == (255, 0, 255), axis=-1)
        assert magenta[:, : W // 2].all() and magenta[H // 2 :, :].all()
        assert not magenta[: H // 2, W // 2 :].any()
        assert target.viewport == (0, 0, W, H)
    finally:
        ctx.detect_framebuffer(0).use()
        for fbo in (target, other):
            for attachment in fbo.color_attachments:
                attachment.release()
            fbo.release()


def test_a_frame_request_refuses_an_unknown_mode_and_names_the_allowed():
    camera, sky = Camera.look_at((0.0, 2.0, 3.0), (0.0, 0.0, 0.0)), sky_at(10.0)
    with pytest.raises(ValueError, match="unknown render mode 'shiny'; allowed: full"):
        FrameRequest(camera, sky, "shiny")
    assert FrameRequest(camera, sky, "normals").debug and not FrameRequest(camera, sky).debug
    # A viewport of floats (a Qt size times a device pixel ratio) is whole pixels.
    assert FrameRequest(camera, sky, viewport=(0.0, 0, 64.0, 48)).viewport == (0, 0, 64, 48)
