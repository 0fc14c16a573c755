"""The renderer over thousands of frames with everything that changes between frames changing:
the clock (so the shadow maps are redrawn), the camera (so the terrain, the sphere and the
cascades are refitted), the frame size (so the post chain and the shadow atlas are made
again), the shadows and the relief toggled. GL objects and Python memory stay flat, and the
renderer releases everything it made."""

from __future__ import annotations

import gc
import tracemalloc

import pytest

from sand_editor.render.camera import camera_at_distance
from sand_editor.render.post import DEFAULT_BLOOM_STRENGTH
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.render.terrain import sphere_mesh
from tests.gl_objects import live_gl_objects
from tests.render.conftest import renderer_with_material

pytestmark = [pytest.mark.gl, pytest.mark.slow]

FRAMES = 2000
SIZES = ((32, 24), (48, 20), (600, 20))  # the last needs cascades of 1024², the others 512²


def _frame(renderer, index: int) -> None:
    """Frame ``index`` of the soak: the camera and the clock jump every tenth frame (every map
    drawn again) and the clock creeps in between (one map a frame)."""
    size = SIZES[(index // 50) % len(SIZES)]
    step = index // 10
    distance = (0.02, 0.3, 3.0, 40.0)[step % 4]
    heading = (step * 37.0) % 360.0
    camera = camera_at_distance(distance, 25.0, size[0] / size[1], renderer.terrain.height,
                                heading_deg=heading, target_xz=(0.1 * step, 0.0))  # fmt: skip
    renderer.shadows = index % 97 != 0
    renderer.relief = index % 89 != 0
    hours = 5.8 + (step * 0.37) % 17.0 + 0.002 * (index % 10)  # sun, moon, neither
    # Metering and bloom (a dozen passes, the most of a small frame's time here) every tenth.
    metered = index % 10 == 0
    renderer.bloom_strength = DEFAULT_BLOOM_STRENGTH if metered else 0.0
    exposure = None if metered else 1.0
    request = FrameRequest(camera, sky_at(hours), show_sphere=step % 3 == 0, exposure=exposure)
    renderer.render_to_array(*size, request)


def test_thousands_of_changing_frames_keep_gl_objects_and_memory_flat(gl_clean):
    with renderer_with_material(gl_clean) as renderer:
        ground = float(renderer.terrain.height(0.0, -1.0))
        centre = (0.0, ground + 0.3, -1.0)
        renderer.add_object(sphere_mesh(centre, 0.3, 16, origin=centre), centre)
        for index in range(3 * 50):  # every size once: all that is kept is made
            _frame(renderer, index)
        gc.collect()
        objects = live_gl_objects(gl_clean)
        tracemalloc.start()
        try:
            for index in range(150, 150 + FRAMES // 2):
                _frame(renderer, index)
            gc.collect()
            middle, _ = tracemalloc.get_traced_memory()
            for index in range(150 + FRAMES // 2, 150 + FRAMES):
                _frame(renderer, index)
            gc.collect()
            end, _ = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert live_gl_objects(gl_clean) == objects
        assert end - middle < 256 * 1024, f"Python memory grew by {end - middle} bytes"
        assert renderer.shadow_maps_drawn > FRAMES // 4


def test_the_renderer_releases_everything_it_made(gl_clean):
    from sand_editor.preset import Preset
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    material = SandMaterial(gl_clean, 64)
    material.update(Preset())
    try:
        before = live_gl_objects(gl_clean)
        renderer = SandRenderer(gl_clean)
        renderer.set_material(material)
        for index in range(0, 300, 25):
            _frame(renderer, index)
        assert live_gl_objects(gl_clean)["Texture"] > before["Texture"]
        renderer.release()
        assert live_gl_objects(gl_clean) == before
    finally:
        material.release()
