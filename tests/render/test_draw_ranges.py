"""Each surface variant draws only what it can shade: the near one the terrain's rings within
the close limit, the far one those beyond it and nothing outside the blended modes; and a
moving view's shadow maps are drawn again one a frame. Pixel for pixel the frames are those
of drawing everything."""

from __future__ import annotations

import math
import sys
import threading

import numpy as np
import pytest

from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.render.terrain import sphere_mesh

pytestmark = pytest.mark.gl

SIZE = (96, 54)
VIEWS = [  # distance, pitch, heading, mode, sphere
    (0.05, 15.0, 0.0, "full", False),
    (1.0, 45.0, 30.0, "full", True),
    (4.0, 30.0, 120.0, "reference-look", False),
    (30.0, 10.0, 200.0, "full", False),
    (100.0, 35.0, 300.0, "full", True),
    (3.0, 89.0, 10.0, "full", False),
    (10.0, 20.0, 5.0, "close", False),
    (10.0, 20.0, 5.0, "far", False),
    (30.0, 10.0, 5.0, "blend", False),
]


def _camera(renderer, distance, pitch, heading):
    return camera_at_distance(
        distance, pitch, SIZE[0] / SIZE[1],
        ground_height=lambda x, z: float(renderer.terrain.height(x, z)), heading_deg=heading,
    )  # fmt: skip


@pytest.mark.parametrize(("distance", "pitch", "heading", "mode", "sphere"), VIEWS)
def test_drawing_each_variants_rings_changes_no_pixel(
    sand_renderer, gl_clean, distance, pitch, heading, mode, sphere
):
    renderer = sand_renderer
    camera = _camera(renderer, distance, pitch, heading)
    request = FrameRequest(camera, sky_at(16.5), mode, exposure=1.0, show_sphere=sphere)
    frames = []
    try:
        for split in (True, False):
            renderer.split_ranges = split
            frames.append(renderer.render_to_array(*SIZE, request))
    finally:
        renderer.split_ranges = True
    assert np.array_equal(frames[0], frames[1])


def test_the_variants_split_the_rings_at_the_close_limit(sand_renderer):
    renderer = sand_renderer
    camera = _camera(renderer, 4.0, 30.0, 0.0)
    terrain = renderer.prepare_frame(camera).terrain
    (near_first, near_count), (far_first, far_count) = renderer._range_runs(terrain, camera, True)
    # Together they draw every ring, and each leaves out what only the other shades.
    assert near_first == 0 and far_first + far_count == terrain.indices
    assert far_first <= near_count < terrain.indices and far_first > 0
    # Outside the blended modes the far variant draws nothing.
    assert renderer._range_runs(terrain, camera, False) == ((0, terrain.indices), (0, 0))


def test_ring_ranges_at_hard_cases(sand_renderer):
    renderer = sand_renderer
    camera = _camera(renderer, 1.0, 45.0, 0.0)
    terrain = renderer.prepare_frame(camera).terrain
    bands = len(terrain.rings) - 1
    per_band = terrain.indices // bands
    eye = np.asarray(camera.eye, dtype=np.float64)
    # No close range at all, or one past the horizon: one variant draws every ring.
    near, far = terrain.ring_ranges(eye, 0.0)
    assert near[1] <= per_band and far == (0, terrain.indices)
    assert terrain.ring_ranges(eye, 1e30) == ((0, terrain.indices), (terrain.indices, 0))
    # An eye 5 km up sees every ring beyond a 10 m limit; one 1 km off the rings' centre
    # (before the next rebuild) is within the limit of none of the inner rings either.
    high = eye + (0.0, 5000.0, 0.0)
    assert terrain.ring_ranges(high, 10.0)[1] == (0, terrain.indices)
    aside = eye + (1000.0, 0.0, 0.0)
    near, far = terrain.ring_ranges(aside, 10.0)
    assert far == (0, terrain.indices) and near[0] == 0
    inside = np.searchsorted(terrain.rings, 1000.0 + 10.0)
    assert near[1] >= (inside - 1) * per_band
    for value in (*near, *far):
        assert isinstance(value, int) and 0 <= value <= terrain.indices
    assert math.isfinite(terrain.rings[-1])


def test_a_moving_view_draws_its_shadow_maps_again_one_a_frame(sand_renderer, gl_clean):
    renderer = sand_renderer
    sky = sky_at(16.5)
    eye = np.array([0.0, float(renderer.terrain.height(0.0, 0.0)) + 1.6, 0.0])

    def turned(degrees):  # the head turning where it stands: the same rings, other slices
        a = math.radians(degrees)
        return Camera.look_at(eye, eye + (math.sin(a), -0.4, -math.cos(a)), aspect=16 / 9)

    size = (320, 180)  # waits long enough to tell a released lock from numpy's own releases
    target = gl_clean.framebuffer([gl_clean.texture(size, 4)])
    try:
        drawn = {}
        for moving in (True, False):
            renderer.render(target, FrameRequest(turned(0.0), sky))
            built = renderer.terrain_meshes_built
            counts = []
            for step in range(1, 4):
                before = renderer.shadow_cascades_drawn
                renderer.render(target, FrameRequest(turned(60.0 * step), sky, moving=moving))
                counts.append(renderer.shadow_cascades_drawn - before)
            assert renderer.terrain_meshes_built == built
            drawn[moving] = counts
        assert max(drawn[True]) <= 1
        assert min(drawn[False]) >= 2  # a still frame draws every map the turn moved off
    finally:
        target.color_attachments[0].release()
        target.release()


def test_objects_are_drawn_whole_by_both_variants(sand_renderer):
    renderer = sand_renderer
    camera = _camera(renderer, 1.0, 45.0, 0.0)
    center = np.asarray(camera.eye) + (0.0, -0.7, -0.7)
    renderer.add_object(sphere_mesh(center, 0.2, 16, origin=center), center)
    try:
        (obj,) = renderer.prepare_frame(camera).objects
        whole = (0, obj.indices)
        assert renderer._range_runs(obj, camera, True) == (whole, whole)
    finally:
        renderer.clear_objects()


def test_a_frame_waited_for_without_the_lock_is_the_same_frame_and_lets_threads_run(
    sand_renderer, gl_clean
):
    # The editor's 3D view draws on a thread of its own with the renderer's waits made without
    # Python's lock, so the GUI thread runs while the CPU rasterizer draws.
    renderer = sand_renderer
    camera = _camera(renderer, 1.0, 45.0, 30.0)
    request = FrameRequest(camera, sky_at(16.5), "full", exposure=None, show_sphere=True)
    count, stop = [0], threading.Event()

    def spin():
        while not stop.wait(0.0005):
            count[0] += 1

    frames, exposures, progress = [], [], []
    size = (320, 180)  # waits long enough to tell a released lock from numpy's own releases
    target = gl_clean.framebuffer([gl_clean.texture(size, 4)])
    interval = sys.getswitchinterval()
    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    try:
        sys.setswitchinterval(30.0)  # the other thread runs only where the lock is given away
        for released in (False, True):
            renderer.wait_without_gil = released
            before = count[0]
            exposures.append(renderer.render(target, request)["exposure"])
            progress.append(count[0] - before)
            frames.append(target.read(components=4))
    finally:
        sys.setswitchinterval(interval)
        renderer.wait_without_gil = False
        stop.set()
        thread.join()
        target.color_attachments[0].release()
        target.release()
    assert frames[0] == frames[1]
    assert exposures[0] == exposures[1]
    # Without, the other thread runs only where numpy and the driver give the lock away (about
    # 16 counts here); with, also while the rasterizer draws (about 160).
    assert progress[1] > 2 * progress[0], progress
