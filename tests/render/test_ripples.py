"""Ripple crests lie across the wind the preset names, on flat ground and over the dunes alike:
the strongest wave of a top-down frame's ripple pattern runs along the wind."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.preset import Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.resources import bundled_preset

pytestmark = pytest.mark.gl

SIZE = 256


@pytest.fixture(scope="module")
def renderer(gl_ctx):
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    material = SandMaterial(gl_ctx, texture_size=128)
    renderer = SandRenderer(gl_ctx)
    yield renderer, material
    renderer.release()
    material.release()


def _wave_bearing(image: np.ndarray) -> float:
    """Compass bearing (mod 180°) of the strongest wave vector of a north-up top-down frame."""
    lum = image.astype(np.float64).mean(axis=2)
    lum -= lum.mean()
    window = np.outer(np.hanning(SIZE), np.hanning(SIZE))
    power = np.abs(np.fft.fftshift(np.fft.fft2(lum * window))) ** 2
    centre = SIZE // 2
    y, x = np.mgrid[:SIZE, :SIZE] - centre
    # Waves longer than ~30 cm are the dunes' slow shading and the ripple field's own large
    # scale (forks, wander), not ripples (6–12 cm: about 50 cycles across this frame).
    power[np.hypot(x, y) < 16] = 0.0
    row, col = np.unravel_index(np.argmax(power), power.shape)
    east, south = col - centre, row - centre  # image x is east, image rows go south
    return math.degrees(math.atan2(east, -south)) % 180.0


@pytest.mark.parametrize("wind", [0.0, 30.0, 90.0, 135.0])
@pytest.mark.parametrize("target", [(0.0, 0.0), (37.0, -55.0)])
def test_the_ripples_run_across_the_wind(renderer, gl_clean, wind, target):
    sand_renderer, material = renderer
    preset = Preset.load(bundled_preset("paper-default")).replace(
        **{"shading.wind_direction": wind, "shading.ripple_strength": 0.3,
           "shading.detail_strength": 0.0}
    )  # fmt: skip
    material.update(preset)
    sand_renderer.set_material(material)
    terrain = sand_renderer.terrain
    camera = camera_at_distance(
        4.0, 90.0, 1.0, lambda x, z: float(terrain.height(x, z)), target_xz=target
    )
    image = sand_renderer.render_to_array(SIZE, SIZE, FrameRequest(camera, sky_at(12.0), "far"))
    bearing = _wave_bearing(image)
    off = abs((bearing - wind + 90.0) % 180.0 - 90.0)
    assert off < 20.0, f"wave at {bearing:.0f}°, wind from {wind:.0f}°"
