"""Shadows: the sun (and at night the moon) casts the sphere's and the dunes' shadows onto the
sand, glints vanish in them, and the maps are fitted to the view, drawn once per frame for both
eyes, and stay finite at every light and height."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.request import FrameRequest
from sand_editor.render.shadows import (
    CASCADE_SIZES,
    CASCADES,
    MAX_SLICE_RATIO,
    cascade_size,
    cascade_splits,
    fit_cascades,
    shadow_light,
)
from sand_editor.render.sky import sky_at
from tests.render.test_renderer import scene_hdr

W, H = 320, 180
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _frustum_points(camera: Camera, near: float, far: float) -> np.ndarray:
    inverse = np.linalg.inv(camera.projection.astype(np.float64))
    rotation = camera.view_relative_to(camera.eye)[:3, :3]
    points = []
    for x in (-1, 1):
        for y in (-1, 1):
            p = inverse @ np.array([x, y, -1.0, 1.0])
            ray = p[:3] / -p[2]
            for depth in (near, far):
                points.append(camera.eye + rotation.T @ (ray * depth))
    return np.array(points)


LIGHTS = {
    "zenith": (0.0, 1.0, 0.0),
    "evening": (0.8, 0.17, -0.2),
    "horizon": (1.0, 1e-4, 0.0),
    "below": (0.0, -0.3, 0.95),
}


@pytest.mark.parametrize("light", LIGHTS.values(), ids=LIGHTS.keys())
@pytest.mark.parametrize("distance", [1e-3, 0.05, 3.0, 100.0, 1.0e4])
def test_cascades_cover_the_view_and_stay_finite(light, distance):
    light = np.asarray(light) / np.linalg.norm(light)
    camera = camera_at_distance(distance, 30.0, 16 / 9)
    clearance = float(camera.eye[1])
    cascades = fit_cascades(camera, light, clearance, rise=10.0)
    assert 1 <= len(cascades) <= CASCADES
    assert (
        all(c.far_m / c.near_m <= MAX_SLICE_RATIO * 1.0001 for c in cascades)
        or len(cascades) == CASCADES
    )
    for cascade in cascades:
        corners = _frustum_points(camera, cascade.near_m, cascade.far_m)
        assert np.linalg.norm(corners - cascade.center, axis=1).max() <= cascade.radius * 1.0001
        for origin in (camera.eye, np.zeros(3), cascade.center + 1e3):
            m = cascade.lookup_matrix(origin)
            assert np.isfinite(m).all()
            # The sphere's centre lands in the middle of the map, in front of the casters.
            centre = m @ np.append(cascade.center - origin, 1.0)
            assert np.allclose(centre[:2], 0.5, atol=1e-6) and 0.0 < centre[2] < 1.0
    assert all(
        a.far_m == pytest.approx(b.near_m) for a, b in zip(cascades, cascades[1:], strict=False)
    )


def test_a_turning_head_keeps_the_maps_size_and_a_moving_one_moves_them_by_whole_texels():
    light = np.array([0.6, 0.3, -0.74])
    light /= np.linalg.norm(light)
    base = camera_at_distance(3.0, 20.0, 16 / 9)
    turned = camera_at_distance(3.0, 25.0, 16 / 9, heading_deg=40.0)
    radii = [c.radius for c in fit_cascades(base, light, 1.0, 10.0)]
    assert radii == [c.radius for c in fit_cascades(turned, light, 1.0, 10.0)]
    moved = camera_at_distance(3.0, 20.0, 16 / 9, target_xz=(0.0123, -0.0457))
    pairs = zip(
        fit_cascades(base, light, 1.0, 10.0), fit_cascades(moved, light, 1.0, 10.0), strict=True
    )
    for a, b in pairs:
        shift = a.axes[:2] @ (b.center - a.center) / a.texel_m
        assert np.allclose(shift, np.round(shift), atol=1e-6)


def test_splits_grow_by_one_ratio():
    splits = cascade_splits(0.01, 100.0, 4)
    assert splits[0] == pytest.approx(0.01) and splits[-1] == pytest.approx(100.0)
    assert np.allclose(splits[1:] / splits[:-1], 10.0)


def test_maps_follow_the_frame_size_within_bounds():
    assert cascade_size((320, 180)) == CASCADE_SIZES[0]
    assert cascade_size((1280, 720)) == 2048 == CASCADE_SIZES[1]
    assert cascade_size((900, 1000)) == 1024
    assert cascade_size((2064, 2208)) == CASCADE_SIZES[1]
    assert cascade_size((0, 0)) == CASCADE_SIZES[0]


def test_the_sun_casts_by_day_the_moon_by_night_and_nothing_when_neither_shines():
    assert shadow_light(sky_at(12.0))[0] == "sun"
    assert shadow_light(sky_at(23.0))[0] == "moon"
    dark = dataclasses.replace(sky_at(23.0), moon_radiance=np.zeros(3, np.float32))
    assert shadow_light(dark) is None
    name, direction = shadow_light(sky_at(17.5))
    assert np.linalg.norm(direction) == pytest.approx(1.0)


# ---- in the renderer -------------------------------------------------------------------------


def _pixel(camera: Camera, point) -> tuple[int, int]:
    clip = camera.view_projection.astype(np.float64) @ np.append(point, 1.0)
    ndc = clip[:3] / clip[3]
    return int((ndc[0] * 0.5 + 0.5) * W), int((0.5 - ndc[1] * 0.5) * H)


def _luminance(renderer, camera, sky, shadows, mode="full", sphere=True):
    renderer.shadows = shadows
    try:
        renderer.render_to_array(
            W, H, FrameRequest(camera, sky, mode, show_sphere=sphere, exposure=1.0)
        )
    finally:
        renderer.shadows = True
    return scene_hdr(renderer)[::-1, :, :3] @ LUMINANCE


def _across_the_light(renderer, distance: float, light) -> Camera:
    """A camera looking across the light, so that a shadow falls to one side of its caster."""
    heading = np.degrees(np.arctan2(light[2], light[0]))
    return camera_at_distance(distance, 35.0, W / H, renderer.terrain.height, heading_deg=heading)


def _shadow_and_lit_pixels(renderer, camera, light):
    """Where the sphere's shadow falls on the ground, and a ground point beside the sphere."""
    sphere = renderer.prepare_frame(camera, show_sphere=True).objects[-1]
    centre = sphere.origin
    radius = sphere.top - centre[1]
    height = renderer.terrain.height
    along = centre - light * (radius / light[1])  # the ray from the sun through the centre …
    for _ in range(4):  # … meets the ground here (a few steps on the gently sloping dunes)
        along = centre - light * ((centre[1] - float(height(along[0], along[2]))) / light[1])
    side = np.array([-light[2], 0.0, light[0]])  # across the light, on the ground
    side /= np.linalg.norm(side)
    lit = centre + 2.5 * radius * side
    lit[1] = float(height(lit[0], lit[2]))
    return _pixel(camera, along), _pixel(camera, lit)


@pytest.mark.gl
@pytest.mark.parametrize("hours", [17.5, 22.0], ids=["sun", "moon"])
def test_the_sphere_casts_its_shadow_on_the_sand(sand_renderer, gl_clean, hours):
    # The sky's own light fills a shadow in; without it, the shadow holds back the direct light.
    sky = dataclasses.replace(sky_at(hours), sky_irradiance=np.zeros(3, dtype=np.float32))
    _, light = shadow_light(sky)
    camera = _across_the_light(sand_renderer, 3.0, light)
    (sx, sy), (lx, ly) = _shadow_and_lit_pixels(sand_renderer, camera, light)
    assert 0 <= sx < W and 0 <= sy < H and 0 <= lx < W and 0 <= ly < H
    with_shadows = _luminance(sand_renderer, camera, sky, True)
    without = _luminance(sand_renderer, camera, sky, False)
    window = np.s_[sy - 2 : sy + 3, sx - 2 : sx + 3]
    lit_window = np.s_[ly - 2 : ly + 3, lx - 2 : lx + 3]
    assert with_shadows[window].mean() < 0.2 * without[window].mean()
    assert with_shadows[lit_window].mean() == pytest.approx(without[lit_window].mean(), rel=0.05)
    assert np.isfinite(with_shadows).all()


@pytest.mark.gl
def test_glints_vanish_in_the_shadow(sand_renderer, gl_clean):
    sky = sky_at(17.5)
    _, light = shadow_light(sky)
    camera = _across_the_light(sand_renderer, 1.0, light)
    full = {on: _luminance(sand_renderer, camera, sky, on) for on in (True, False)}
    shadow = full[True] < 0.3 * full[False]
    assert shadow.mean() > 0.01, "a shadow in view"
    glints = _luminance(sand_renderer, camera, sky, False, mode="glints")[shadow]
    assert (glints > 0.0).sum() >= 3, "glints to vanish"
    shadowed = _luminance(sand_renderer, camera, sky, True, mode="glints")[shadow]
    assert shadowed.sum() < 0.1 * glints.sum()
    # Each pixel's glints dimmed at least as much as its light as a whole (which keeps the sky).
    dimmed = (full[True] / np.maximum(full[False], 1e-9))[shadow]
    assert np.all(shadowed <= glints * dimmed * 1.01 + 1e-6)


@pytest.mark.gl
def test_dunes_shade_each_other_at_sunset_and_not_at_noon(sand_renderer, gl_clean):
    camera = camera_at_distance(100.0, 30.0, W / H, sand_renderer.terrain.height)
    shares = {}
    for hours in (12.0, 18.0):
        sky = sky_at(hours)
        on, off = (_luminance(sand_renderer, camera, sky, s, sphere=False) for s in (True, False))
        darker = on < 0.7 * off
        shares[hours] = darker[H // 2 :].mean()
    assert shares[18.0] > 0.03
    assert shares[12.0] < 0.005


@pytest.mark.gl
def test_both_eyes_read_one_drawing_of_the_maps_and_a_still_view_draws_none(
    sand_renderer, gl_clean
):
    head = camera_at_distance(2.0, 30.0, W / H, sand_renderer.terrain.height)
    right = head.view[0, :3].astype(np.float64)
    eyes = []
    for side in (-0.032, 0.032):
        view = head.view.astype(np.float64).copy()
        view[0, 3] -= side
        eyes.append(Camera(view=view, projection=head.projection, eye=head.eye + side * right))
    sky = sky_at(17.0)
    scene = sand_renderer.prepare_frame(head, show_sphere=True)
    target = sand_renderer.ctx.framebuffer([sand_renderer.ctx.texture((W, H), 4)])
    try:
        before = sand_renderer.shadow_maps_drawn
        for eye in eyes:
            sand_renderer.render(target, FrameRequest(eye, sky, scene=scene, exposure=1.0))
        assert sand_renderer.shadow_maps_drawn == before + 1
        for eye in eyes:  # the next frame, nothing moved
            sand_renderer.render(target, FrameRequest(eye, sky, scene=scene, exposure=1.0))
        assert sand_renderer.shadow_maps_drawn == before + 1
        sand_renderer.render(
            target, FrameRequest(eyes[0], sky_at(17.01), scene=scene, exposure=1.0)
        )
        assert sand_renderer.shadow_maps_drawn == before + 2
    finally:
        target.color_attachments[0].release()
        target.release()


@pytest.mark.gl
@pytest.mark.parametrize("hours", [5.6, 5.75, 6.0, 12.0, 18.2, 18.35, 0.0, 3.0])
@pytest.mark.parametrize("distance", [1e-3, 1.0, 1.0e3])
def test_low_and_high_lights_render_finite_frames(sand_renderer, gl_clean, hours, distance):
    camera = camera_at_distance(distance, 20.0, W / H, sand_renderer.terrain.height)
    luminance = _luminance(sand_renderer, camera, sky_at(hours), True)
    assert np.isfinite(luminance).all() and luminance.min() >= 0.0


@pytest.mark.gl
def test_a_playing_clock_redraws_one_map_a_frame_and_a_jump_redraws_all(sand_renderer, gl_clean):
    from sand_editor.render.shadows import MAX_LIGHT_LAG_DEG, SunShadows

    head = camera_at_distance(2.0, 30.0, W / H, sand_renderer.terrain.height)
    scene = sand_renderer.prepare_frame(head)
    meshes = (scene.terrain, *scene.objects)
    shadows = SunShadows(sand_renderer.ctx)
    try:

        def lights(hours):
            frame = shadows.update(meshes, head, sky_at(hours), 1.0, 10.0, (W, H))
            return [tuple(c.axes[2]) for c in frame.cascades]

        first = lights(17.0)
        step = 0.2 * MAX_LIGHT_LAG_DEG / 15.0  # hours for a fifth of the lag: the sun's 15°/h
        second = lights(17.0 + step)
        assert sum(a != b for a, b in zip(first, second, strict=True)) == 1
        count = len(first)
        assert count > 2
        later = [lights(17.0 + step) for _ in range(count - 1)]  # the clock stops
        behind = [sum(a != b for a, b in zip(f, later[-1], strict=True)) for f in later]
        assert behind == list(range(count - 2, -1, -1))
        assert len(set(later[-1])) == 1, "every map caught up with the light"
        jumped = lights(17.5)
        assert len(set(jumped)) == 1 and jumped[0] != later[-1][0]
    finally:
        shadows.release()


def test_a_map_draws_the_rings_that_can_cast_into_it_and_every_other_mesh_whole():
    from types import SimpleNamespace

    from sand_editor.render.shadows import caster_range

    rings = np.concatenate([[0.0], 2.0 ** np.arange(12)])  # 0, 1, 2 … 2048 m
    per_band = 6 * 8
    terrain = SimpleNamespace(rings=rings, ring_center=np.zeros(2), indices=per_band * 12)
    light = np.array([0.0, 1.0, 0.0])  # straight down: casters only above the sphere
    camera = camera_at_distance(3.0, 30.0, 16 / 9)
    cascade = fit_cascades(camera, light, 1.5, rise=0.0)[0]
    distance = float(np.hypot(cascade.center[0], cascade.center[2]))
    first, count = caster_range(terrain, cascade)
    assert first % per_band == 0 and count % per_band == 0 and count > 0
    inner, outer = rings[first // per_band], rings[(first + count) // per_band]
    assert inner <= max(distance - cascade.radius, 0.0) and outer >= distance + cascade.radius
    assert count < terrain.indices, "rings beyond the map are left out"
    # A low sun reaches far: the rings out to where a caster can still shade the map are drawn.
    low = fit_cascades(camera, np.array([0.99, 0.14, 0.0]), 1.5, rise=5.0)[0]
    first, count = caster_range(terrain, low)
    assert rings[(first + count) // per_band] >= 0.99 * low.reach + low.radius
    assert count > caster_range(terrain, cascade)[1]
    sphere = SimpleNamespace(indices=999)
    assert caster_range(sphere, cascade) == (0, 999)
