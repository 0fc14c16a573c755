"""Scene objects chosen once per frame from the head, shared by every eye's draw."""

from __future__ import annotations

import numpy as np

from sand_editor.render.camera import Camera, look_at_matrix, perspective
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.render.terrain import sphere_mesh
from tests.render.conftest import renderer_with_material

SIZE = (48, 36)


def _camera(eye, target) -> Camera:
    return Camera(look_at_matrix(eye, target), perspective(70.0, 4 / 3, 0.005, 5000.0), eye)


def _straddling_eyes(renderer):
    """Two eyes 63 mm apart whose terrain rings would snap to different centres."""
    ground = float(renderer.terrain.height(0.0, 0.0))
    # 1.6 m above the ground: ring spacing 0.125 m, snap 0.25 m; x = 0.125 is a snap edge.
    y = ground + 1.6
    left = np.array([0.125 - 0.0315, y, 0.0])
    right = np.array([0.125 + 0.0315, y, 0.0])
    ahead = np.array([0.0, -0.5, -1.0])
    return (
        [_camera(e, e + ahead) for e in (left, right)],
        _camera((left + right) / 2, (left + right) / 2 + ahead),
    )


def test_per_eye_choice_rebuilds_terrain_between_eyes_but_a_frame_scene_does_not(
    sand_renderer, gl_clean
):
    renderer = sand_renderer
    eyes, head = _straddling_eyes(renderer)
    target = gl_clean.framebuffer([gl_clean.texture(SIZE, 4)])
    sky = sky_at(10.0)
    try:
        # Without a scene each eye chooses its own level of detail: two frames rebuild often.
        before = renderer.terrain_meshes_built
        for _ in range(2):
            for eye in eyes:
                renderer.render(target, FrameRequest(eye, sky))
        per_eye_builds = renderer.terrain_meshes_built - before
        assert per_eye_builds >= 3

        before = renderer.terrain_meshes_built
        for _ in range(3):
            scene = renderer.prepare_frame(head)
            for eye in eyes:
                renderer.render(target, FrameRequest(eye, sky, scene=scene))
        assert renderer.terrain_meshes_built - before <= 1
    finally:
        for texture in target.color_attachments:
            texture.release()
        target.release()


def test_both_eyes_of_a_frame_draw_the_same_sphere(sand_renderer, gl_clean):
    eyes, head = _straddling_eyes(sand_renderer)
    scene = sand_renderer.prepare_frame(head, show_sphere=True)
    assert len(scene.objects) == 1
    again = sand_renderer.prepare_frame(head, show_sphere=True)
    assert again.objects[0] is scene.objects[0]
    assert sand_renderer.prepare_frame(head, show_sphere=False).objects == ()


def test_fixed_objects_are_drawn_in_the_sand_material(gl_ctx):
    with renderer_with_material(gl_ctx) as renderer:
        ground = float(renderer.terrain.height(0.0, -1.0))
        eye = np.array([0.0, ground + 1.0, 0.5])
        camera = _camera(eye, (0.0, ground + 0.5, -1.0))
        sky = sky_at(12.0)
        without = renderer.render_to_array(*SIZE, FrameRequest(camera, sky))
        center = (0.0, ground + 0.5, -1.0)
        renderer.add_object(sphere_mesh(center, 0.3, 24, origin=center), center)
        scene = renderer.prepare_frame(camera)
        assert len(scene.objects) == 1
        with_sphere = renderer.render_to_array(*SIZE, FrameRequest(camera, sky))
        changed = np.any(with_sphere != without, axis=-1)
        assert changed[
            SIZE[1] // 2 - 3 : SIZE[1] // 2 + 3, SIZE[0] // 2 - 3 : SIZE[0] // 2 + 3
        ].all()
        hdr = np.frombuffer(renderer.post.scene_texture.read(), dtype=np.float16)
        assert np.isfinite(hdr).all(), "no NaN or inf in the HDR frame with the sphere"
