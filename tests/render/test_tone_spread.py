"""The tone curve takes the spread of each pixel's light: a frame shows what the same view drawn
finer and averaged shows, not its footprints' mean light put through the curve's shoulder."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.colour import srgb_to_linear
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.exposure import light_exposure
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from tests.render.test_renderer import scene_hdr

pytestmark = pytest.mark.gl

W, H = 160, 90
K = 8


@pytest.fixture
def renderer(fine_sand_renderer):
    return fine_sand_renderer


def _camera(renderer, distance):
    terrain = renderer.terrain
    return camera_at_distance(distance, 15.0, W / H, lambda x, z: float(terrain.height(x, z)))


def _ground_light(image: np.ndarray, factor: int) -> float:
    """The mean linear light of the ground (lower half) of a tone-mapped frame, its pixels
    averaged factor×factor first, as the eye sees a finer frame."""
    linear = srgb_to_linear(image / 255.0)
    h, w = linear.shape[0] // factor, linear.shape[1] // factor
    linear = linear[: h * factor, : w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
    return float(linear[h // 2 :].mean())


@pytest.mark.parametrize("distance", [0.3, 1.0])
def test_a_frame_shows_the_light_of_the_finer_frame_averaged(renderer, gl_clean, distance):
    camera, sky = _camera(renderer, distance), sky_at(16.5)
    exposure = light_exposure(sky)  # one exposure for both: no metering of either
    shown = {}
    for k in (1, K):
        request = FrameRequest(camera, sky, "full", exposure=exposure)
        shown[k] = _ground_light(renderer.render_to_array(W * k, H * k, request), k)
    # The footprint's mean light through the curve gave 1.07 (0.3 m) and 1.06 (1 m).
    print(distance, shown[1] / shown[K])
    assert shown[1] / shown[K] < 1.045, shown


def test_the_spread_is_written_where_the_close_range_shades(renderer, gl_clean):
    """The scene's alpha: finite and never negative, 0 on the sky, above 0 on the ground up
    close, and nothing on the ground in a debug mode."""
    camera, sky = _camera(renderer, 0.3), sky_at(16.5)
    renderer.render_to_array(W, H, FrameRequest(camera, sky, "full"))
    spread = scene_hdr(renderer)[::-1, :, 3]  # rows top-down
    assert np.isfinite(spread).all() and spread.min() >= 0.0
    assert spread[:3].max() == 0.0  # the sky, above the horizon
    assert np.median(spread[H // 2 :]) > 0.01, np.median(spread[H // 2 :])
    renderer.render_to_array(W, H, FrameRequest(camera, sky, "normals"))
    assert scene_hdr(renderer)[:, :, 3].max() == 0.0
