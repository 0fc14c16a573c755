"""A still drawn with k×k samples a pixel (``SandRenderer.render_still``, ``render --samples``):
k×k frames each moved by a fraction of a pixel and filtering the sand over that share of it,
whose light is the light of the frame k times larger, averaged over each pixel."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sand_editor.colour import luminance
from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.exposure import light_exposure
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from tests.render.test_renderer import scene_hdr

pytestmark = pytest.mark.gl

W, H = 160, 90


@pytest.fixture
def renderer(fine_sand_renderer):
    return fine_sand_renderer


K = 2  # the stills' samples a pixel on each axis


def _request(renderer, distance, size=(W, H)) -> FrameRequest:
    terrain = renderer.terrain
    camera = camera_at_distance(
        distance, 15.0, size[0] / size[1], lambda x, z: float(terrain.height(x, z))
    )
    sky = sky_at(16.5)
    return FrameRequest(camera, sky, "full", exposure=light_exposure(sky))


def _light(renderer) -> np.ndarray:
    """The scene target's light, rows top-down."""
    return scene_hdr(renderer)[::-1, :, :3].astype(np.float64)


def _ground_error(light: np.ndarray, truth: np.ndarray) -> float:
    """Mean absolute difference of luminance over the ground, over the truth's mean there; the
    sparkles, tens of times the sand's light, capped at three times its mean (a sparkle's draw
    may fall in the next pixel, and would outweigh the grains)."""
    a, b = luminance(light[H // 2 :]), luminance(truth[H // 2 :])
    cap = 3.0 * b.mean()
    return float(np.abs(np.minimum(a, cap) - np.minimum(b, cap)).mean() / b.mean())


@pytest.mark.parametrize("distance", [0.05, 0.3])
def test_a_still_holds_the_light_of_the_larger_frame(renderer, gl_clean, distance):
    """Up close, where the grains' outlines, relief and sparkles lie within a pixel, the still's
    light is the larger frame's averaged over each pixel (to the half floats' rounding and the
    few sparkles a pixel's own draw places differently); k×k frames that each filter a whole
    pixel, as a frame of the still's size does, are ten times further off."""
    renderer.render_to_array(W * K, H * K, _request(renderer, distance, (W * K, H * K)))
    larger = _light(renderer).reshape(H, K, W, K, 3).mean(axis=(1, 3))

    request = _request(renderer, distance)
    renderer.render_still(W, H, request, K)
    still = _light(renderer)  # the average the still resolved

    offsets = (np.arange(K) + 0.5) / K - 0.5
    whole_pixels = np.zeros_like(still)
    for dy in offsets:
        for dx in offsets:
            shifted = request.camera.shifted(-dx, -dy, (W, H))
            renderer.render_to_array(W, H, dataclasses.replace(request, camera=shifted))
            whole_pixels += _light(renderer) / K**2

    assert np.isfinite(still).all()
    error, unfiltered = _ground_error(still, larger), _ground_error(whole_pixels, larger)
    # Measured: 0.004 / 0.016 against 0.052 / 0.165 at 0.05 / 0.3 m.
    assert error < 0.25 * unfiltered, (error, unfiltered)
    assert error < 0.03, error


def test_one_sample_is_the_frame(renderer, gl_clean):
    request = _request(renderer, 1.0)
    assert np.array_equal(
        renderer.render_still(W, H, request, 1), renderer.render_to_array(W, H, request)
    )


def test_a_still_keeps_its_sparkles_and_its_light(renderer, gl_clean):
    """Its light is gathered before the tone curve, as a camera's pixel gathers it: a sparkle
    still brings its pixel the light it brings to the frame (averaged after the curve, the
    frames' sparkles would each shrink to a k²-th of white); the ground's light is the
    frame's."""
    request = _request(renderer, 0.3)
    frame = renderer.render_to_array(W, H, request) / 255.0
    still = renderer.render_still(W, H, request, K) / 255.0
    assert still.shape == frame.shape and still.dtype == np.float64

    def sparkles(image):
        return int((luminance(image[H // 2 :]) > 0.85).sum())

    assert sparkles(frame) > 5
    assert sparkles(still) > 0.5 * sparkles(frame), (sparkles(still), sparkles(frame))
    ground = slice(H // 2, None)
    ratio = luminance(still[ground]).mean() / luminance(frame[ground]).mean()
    assert ratio == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("samples", [0, 9, -1, 2.0, True, None, "2"])
def test_samples_outside_one_to_eight_are_refused(renderer, samples):
    with pytest.raises(ValueError, match="samples"):
        renderer.render_still(W, H, _request(renderer, 1.0), samples)


def test_a_still_fills_its_frame(renderer):
    request = dataclasses.replace(_request(renderer, 1.0), viewport=(0, 0, W // 2, H))
    with pytest.raises(ValueError, match="viewport"):
        renderer.render_still(W, H, request, 2)


@pytest.mark.parametrize("scale", [0.0, -0.5, 1.5, float("nan")])
def test_a_footprint_outside_a_pixel_is_refused(renderer, scale):
    with pytest.raises(ValueError, match="footprint_scale"):
        dataclasses.replace(_request(renderer, 1.0), footprint_scale=scale)


def test_a_shifted_camera_moves_the_image_by_those_pixels():
    camera = Camera.look_at((0.0, 1.0, 5.0), (0.0, 0.0, 0.0), aspect=2.0)
    point = np.array([0.3, 0.2, -0.4, 1.0])

    def pixel(cam: Camera, size) -> np.ndarray:
        clip = cam.view_projection.astype(np.float64) @ point
        ndc = clip[:2] / clip[3]
        return (ndc + 1.0) * 0.5 * np.asarray(size)

    size = (200, 100)
    moved = pixel(camera.shifted(1.5, -0.25, size), size) - pixel(camera, size)
    assert moved == pytest.approx([1.5, -0.25], abs=1e-3)
