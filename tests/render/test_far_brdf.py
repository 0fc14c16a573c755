"""The numpy far field (render/far_brdf.py) against the shader it stands for: the probe's far
mode at the centre of the frame, where the eye direction is the camera's, with the glints
turned off (no clear grains), so that the diffuse light is all of it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.bench.probe import MaterialProbe
from sand_editor.export.maps import normal_moments
from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.render.far_brdf import (
    far_radiance_per_irradiance,
    five_normals_correction,
    grain_tilts,
    hemisphere,
    sphere_brdf,
)
from sand_editor.render.material import SandMaterial
from sand_editor.resources import bundled_preset

SIZE = 256
# Sun elevation and azimuth, eye pitch; a low sun and a grazing eye, where the five normals'
# correction is largest.
VIEWS = [(45.0, 90.0, 60.0), (60.0, 180.0, 60.0), (80.0, 90.0, 85.0), (20.0, 180.0, 20.0),
         (20.0, 0.0, 20.0)]  # fmt: skip


def _surface(direction: np.ndarray) -> np.ndarray:
    """World (x east, y up, z south) to the plane's tangent frame (+x, −z, +y)."""
    return np.array([direction[0], -direction[2], direction[1]])


@pytest.mark.gl
@pytest.mark.parametrize("name", ["paper-default", "pale-quartz"])
def test_the_numpy_far_field_matches_the_shaders(gl_ctx, name):
    preset = Preset.load(bundled_preset(name))
    textures = generate(preset, SIZE, ctx=gl_ctx)
    moments = normal_moments(textures.normal)
    tilts = grain_tilts(textures.normal[..., :2])
    material = SandMaterial(gl_ctx, SIZE)
    # The numpy far field is the diffuse shading: no clear grains, no glints beside it.
    material.update(preset.replace(**{"shading.clear_grains": 0.0}), grains=textures)
    probe = MaterialProbe(material, 64, 64)
    try:
        probe.sky_irradiance = np.zeros(3)
        probe.ripples = False
        for elevation, azimuth, pitch in VIEWS:
            e, a = math.radians(elevation), math.radians(azimuth)
            sun = np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])
            probe.sun_direction = sun
            camera = probe.camera(3.0, pitch)
            pixels, _ = probe.render(camera, "far")
            shader = pixels[30:34, 30:34].reshape(-1, 3).mean(axis=0)
            eye = camera.position / np.linalg.norm(camera.position)
            ours = (
                far_radiance_per_irradiance(
                    preset, textures.average_albedo, moments, _surface(sun), _surface(eye), tilts
                )
                * probe.sun_radiance
            )
            assert np.all(np.abs(ours / shader - 1.0) < 0.02), (elevation, azimuth, ours, shader)
    finally:
        probe.release()
        material.release()


def test_deons_brdf_is_reciprocal_and_bounded():
    rng = np.random.default_rng(5)
    kd = rng.uniform(1e-4, 1.0, 200)
    ui, uo = rng.uniform(1e-6, 1.0, 200), rng.uniform(1e-6, 1.0, 200)
    phi = rng.uniform(0.0, 2.0 * np.pi, 200)
    cos_io = ui * uo + np.sqrt((1 - ui**2) * (1 - uo**2)) * np.cos(phi)
    forward, backward = sphere_brdf(kd, ui, uo, cos_io), sphere_brdf(kd, uo, ui, cos_io)
    assert np.all(np.isfinite(forward)) and np.all(forward >= 0.0)
    assert np.allclose(forward, backward)
    assert np.all(sphere_brdf(kd, -ui, uo, cos_io) == 0.0), "nothing from below the horizon"


def test_a_flat_tile_needs_no_correction_of_its_five_normals():
    """Upright normals are the five's exactly, whatever the light and the eye: each band of
    tilt stands at its normals' mean cosine, not its middle (the top band's middle, 10° off
    upright, drew bright rings on a sand without grains where ripples tilt the light)."""
    tilts = grain_tilts(np.zeros((64, 64, 2)))
    eyes = hemisphere(6)[0]
    for cos_light in (0.05, 0.3, 0.7, 1.0):
        light = np.array([math.sqrt(1.0 - cos_light**2), 0.0, cos_light])
        ratio = five_normals_correction(tilts, (0.0, 0.0, 0.0, 0.0), light, eyes)
        np.testing.assert_allclose(ratio, 1.0, atol=1e-9)
