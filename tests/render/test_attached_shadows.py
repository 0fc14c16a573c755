"""Shadows that touch what casts them: a post standing in the sand (drawn as the workbench's
desk is, in plain colours, and given to the renderer as a caster) shades the sand from its foot
to the tip of its shadow, no further, and a box in its shadow is shaded too; the first cascade
starts at the nearest object, so a desk leaned over gets the finest map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.colour import LUMINANCE
from sand_editor.render.camera import Camera
from sand_editor.render.request import FrameRequest
from sand_editor.render.shadows import fit_cascades, nearest_depth
from sand_editor.render.sky import sky_at
from sand_editor.vr.bench_draw import BenchGraphics
from sand_editor.vr.bench_meshes import box_props
from tests.render.conftest import renderer_with_material
from tests.render.test_renderer import scene_hdr

SIZE = 480
POST = (0.05, 0.8, 0.05)  # width, height above the sand, depth
SINK = 0.05  # how deep the post stands in the sand
BOX = (0.1, 0.04, 0.1)
HOURS = 17.0  # the sun 22° high: a shadow 1.9 m long


class _Scene:
    """The post at ``foot`` (x, z) with its shadow's direction along the sand, a box in its
    shadow and one beside it, drawn from straight above the shadow's first half metre."""

    def __init__(self, renderer, graphics) -> None:
        self.renderer, self.graphics = renderer, graphics
        self.sky = sky_at(HOURS)
        sun = np.asarray(self.sky.sun_direction, dtype=np.float64)
        along = -np.array([sun[0], 0.0, sun[2]])
        self.along = along / np.linalg.norm(along)
        self.across = np.cross(self.along, (0.0, 1.0, 0.0))
        self.tan_elevation = sun[1] / math.hypot(sun[0], sun[2])
        self.foot = np.array([1.3, 0.0, -0.7])
        self.foot[1] = self._ground(self.foot)
        post_center = self.foot + (0.0, (POST[1] - SINK) / 2, 0.0)
        post = box_props(post_center, (POST[0], POST[1] + SINK, POST[2]), (0.3, 0.3, 0.3))
        self.boxes = [self.ground_point(0.3, side) for side in (0.0, 0.4)]
        boxes = [box_props(b + (0, BOX[1] / 2 - 0.01, 0), BOX, (0.5, 0.5, 0.5)) for b in self.boxes]
        self.props = np.vstack([post, *boxes])
        middle = self.ground_point(0.25, 0.1)
        self.camera = Camera.look_at(middle + (0.0, 1.2, 0.0), middle, fov_y_deg=60.0, aspect=1.0)

    def _ground(self, point) -> float:
        return float(self.renderer.terrain.height(point[0], point[2]))

    def ground_point(self, along_m: float, across_m: float = 0.0) -> np.ndarray:
        p = self.foot + along_m * self.along + across_m * self.across
        p[1] = self._ground(p)
        return p

    def render(self, casts: bool) -> np.ndarray:
        """Linear luminance of the HDR scene, rows bottom-up."""
        self.renderer.clear_objects()
        if casts:
            self.renderer.add_caster(self.props[:, :3], self.foot)
        self.graphics.set_fixed(self.props, self.foot)

        def draw(camera, sky, shadows):
            self.graphics.draw_props(camera, sky, None, shadows)

        self.renderer.render_to_array(
            SIZE, SIZE, FrameRequest(self.camera, self.sky, exposure=1.0, extra=draw)
        )
        return scene_hdr(self.renderer)[..., :3] @ np.asarray(LUMINANCE, np.float32)

    def luminance(self, image: np.ndarray, point) -> float:
        """The median of the 5 × 5 pixels around where ``point`` (world) is seen."""
        clip = self.camera.view_projection.astype(np.float64) @ np.append(point, 1.0)
        x, y = ((clip[:2] / clip[3]) + 1.0) / 2.0 * SIZE
        column, row = int(x), int(y)
        assert 2 <= column < SIZE - 2 and 2 <= row < SIZE - 2, "outside the view"
        return float(np.median(image[row - 2 : row + 3, column - 2 : column + 3]))


@pytest.fixture(scope="module")
def scene(gl_ctx):
    with renderer_with_material(gl_ctx) as renderer:
        graphics = BenchGraphics(gl_ctx, (64, 32))
        try:
            yield _Scene(renderer, graphics)
        finally:
            graphics.release()


def test_a_post_s_shadow_starts_at_its_foot_and_ends_at_its_tip(scene, gl_clean):
    lit, shaded = scene.render(casts=False), scene.render(casts=True)
    assert np.isfinite(shaded).all()
    length = POST[1] / scene.tan_elevation
    # Just outside the post's foot (its half-width is 2.5 cm), and on along the shadow.
    for along in (0.035, 0.05, 0.1, 0.2, 0.5):
        point = scene.ground_point(along)
        dark, bright = scene.luminance(shaded, point), scene.luminance(lit, point)
        assert dark < 0.45 * bright, f"{along} m from the foot: {dark:.3g} against {bright:.3g}"
    # Beside the shadow and before the post, the sand is lit as it was without the post.
    for along, across in ((0.1, 0.12), (0.1, -0.12), (-0.1, 0.0)):
        point = scene.ground_point(along, across)
        ratio = scene.luminance(shaded, point) / scene.luminance(lit, point)
        assert ratio == pytest.approx(1.0, abs=0.05), (along, across)
    assert length > 1.0  # the tip lies out of view: its end is checked by the cascades' test


def test_a_box_in_the_post_s_shadow_is_shaded_and_one_beside_it_is_not(scene, gl_clean):
    lit, shaded = scene.render(casts=False), scene.render(casts=True)
    top = (0.0, BOX[1] - 0.01, 0.0)
    in_shadow, beside = (scene.luminance(image, scene.boxes[0] + top) for image in (shaded, lit))
    assert in_shadow < 0.4 * beside
    assert scene.luminance(shaded, scene.boxes[1] + top) == pytest.approx(
        scene.luminance(lit, scene.boxes[1] + top), rel=0.02
    )


def test_the_first_cascade_starts_at_the_nearest_object_in_view():
    eye = np.array([0.0, 0.9, 0.0])
    head = Camera.look_at(eye, (0.0, 0.7, -0.3), fov_y_deg=90.0, aspect=1.0, near=0.005)
    desk = np.array([[-0.5, 0.0, -0.45], [0.5, 0.8, -0.1]])
    behind = np.array([[-0.5, 0.9, 0.5], [0.5, 1.5, 1.0]])
    nearest = nearest_depth(head, [desk, behind])
    assert 0.0 < nearest < 0.2  # the desk's near edge, 10 cm ahead; the box behind is not seen
    assert nearest_depth(head, [behind]) == math.inf
    light = (0.5, 0.6, -0.3)
    ground_only = fit_cascades(head, light, 0.9, 1.0, 1024)
    with_desk = fit_cascades(head, light, 0.9, 1.0, 1024, nearest=nearest)
    assert with_desk[0].near_m == pytest.approx(nearest)
    # A texel of the desk's map is many times finer than the ground's first map.
    assert with_desk[0].texel_m < ground_only[0].texel_m / 4
