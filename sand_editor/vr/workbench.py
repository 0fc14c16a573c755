"""The workbench: a block of sand at hand height with a sand sphere on it, and a panel at its
back showing the time, day speed, sand and mode, with buttons pressed by aiming a controller
ray at them and pulling the trigger."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sand_editor.gl import GLObjects, program, render_state, set_matrix
from sand_editor.render.camera import Camera
from sand_editor.render.terrain import _grid_index, sphere_mesh
from sand_editor.view import ViewState, format_time
from sand_editor.vr.actions import Command

TABLE_HEIGHT_M = 0.85  # top of the block above the ground
TABLE_SIZE_M = (0.7, 0.45)  # width (x), depth (z)
TABLE_DISTANCE_M = 0.65  # from the standing point to the block's centre, northwards (−z)
SPHERE_RADIUS_M = 0.07
PANEL_SIZE_M = (0.48, 0.27)
PANEL_TILT_DEG = 25.0  # leaning back, towards the sky
PANEL_PIXELS = (768, 432)
RAY_LENGTH_M = 3.0

# Buttons in panel coordinates (u right, v up, 0..1), one row along the bottom edge:
# name → (u0, v0, u1, v1, label, command).
_BUTTON_ROW = [
    ("earlier", "-1 h", Command("scrub", -1.0)),
    ("later", "+1 h", Command("scrub", 1.0)),
    ("play", "play", Command("play_pause")),
    ("slower", "slower", Command("speed_step", -1)),
    ("faster", "faster", Command("speed_step", 1)),
    ("sand", "sand >", Command("next_preset")),
    ("lambert", "Lambert", Command("toggle_lambert")),
]
_ROW_V = (0.04, 0.21)
_ROW_U = (0.015, 0.985)
_GAP_U = 0.008
_WIDTH_U = (_ROW_U[1] - _ROW_U[0] - _GAP_U * (len(_BUTTON_ROW) - 1)) / len(_BUTTON_ROW)
BUTTONS = {
    name: (
        _ROW_U[0] + i * (_WIDTH_U + _GAP_U),
        _ROW_V[0],
        _ROW_U[0] + i * (_WIDTH_U + _GAP_U) + _WIDTH_U,
        _ROW_V[1],
        label,
        command,
    )
    for i, (name, label, command) in enumerate(_BUTTON_ROW)
}


@dataclass(frozen=True)
class PanelFrame:
    """The panel's rectangle in the world: ``center``, unit ``right`` and ``up`` along its
    edges, ``size`` (width, height) in metres."""

    center: np.ndarray
    right: np.ndarray
    up: np.ndarray
    size: tuple[float, float]

    @cached_property
    def normal(self) -> np.ndarray:
        return np.cross(self.right, self.up)

    def corners(self) -> np.ndarray:
        """(4, 3): bottom-left, bottom-right, top-right, top-left."""
        half_w, half_h = self.size[0] / 2, self.size[1] / 2
        return np.array(
            [
                self.center + sx * half_w * self.right + sy * half_h * self.up
                for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))
            ]
        )

    def hit(self, origin, direction) -> tuple[float, float, float] | None:
        """Where a ray meets the panel, from its front: (u, v, distance), u and v in 0..1;
        None when it misses or comes from behind."""
        origin = np.asarray(origin, dtype=np.float64)
        direction = np.asarray(direction, dtype=np.float64)
        facing = float(np.dot(direction, self.normal))
        if not facing < -1e-9:
            return None
        distance = float(np.dot(self.center - origin, self.normal)) / facing
        if not (distance > 0 and math.isfinite(distance)):
            return None
        offset = origin + distance * direction - self.center
        u = float(np.dot(offset, self.right)) / self.size[0] + 0.5
        v = float(np.dot(offset, self.up)) / self.size[1] + 0.5
        if not (0.0 <= u <= 1.0 and 0.0 <= v <= 1.0):
            return None
        return u, v, distance


def button_at(u: float, v: float) -> str | None:
    for name, (u0, v0, u1, v1, *_rest) in BUTTONS.items():
        if u0 <= u <= u1 and v0 <= v <= v1:
            return name
    return None


def box_mesh(center, size, origin=None) -> dict:
    """An axis-aligned box, each face with its own normal and tangent and ``uv`` in metres
    along the face (same handedness as the terrain: cross(tangent, normal) is +v)."""
    center = np.asarray(center, dtype=np.float64)
    half = np.asarray(size, dtype=np.float64) / 2
    faces = [  # normal, tangent
        ((0, 1, 0), (1, 0, 0)),
        ((0, -1, 0), (1, 0, 0)),
        ((1, 0, 0), (0, 0, -1)),
        ((-1, 0, 0), (0, 0, 1)),
        ((0, 0, 1), (1, 0, 0)),
        ((0, 0, -1), (-1, 0, 0)),
    ]
    positions, normals, tangents, uvs, indices = [], [], [], [], []
    for normal, tangent in faces:
        n, t = np.array(normal, float), np.array(tangent, float)
        b = np.cross(t, n)
        corners = [n * half + su * t * half + sv * b * half for su, sv in _QUAD]
        base = len(positions)
        for corner in corners:
            p = center + corner
            positions.append(p)
            normals.append(n)
            tangents.append(t)
            uvs.append((float(np.dot(p, t)), float(np.dot(p, b))))
        indices.extend(base + _grid_index(2, 2))
    position = np.array(positions)
    if origin is not None:
        position = position - np.asarray(origin, dtype=np.float64)
    return {
        "position": position.astype(np.float32),
        "normal": np.array(normals, np.float32),
        "tangent": np.array(tangents, np.float32),
        "uv": np.array(uvs, np.float32),
        "index": np.array(indices, np.uint32),
    }


_QUAD = ((-1, -1), (1, -1), (-1, 1), (1, 1))  # row-major 2 × 2 grid for _grid_index


class Workbench:
    """Places the block, the sphere and the panel on the ground below ``stand_xz`` and draws
    the panel and the rays over each eye's image."""

    def __init__(self, ground_height, stand_xz=(0.0, 0.0)) -> None:
        x, z = stand_xz[0], stand_xz[1] - TABLE_DISTANCE_M
        ground = float(ground_height(x, z))
        self.table_top = ground + TABLE_HEIGHT_M
        depth_below = 0.3  # the block reaches into the dune, whatever its slope
        height = TABLE_HEIGHT_M + depth_below
        self.table_center = np.array([x, ground + TABLE_HEIGHT_M - height / 2, z])
        self.table_size = (TABLE_SIZE_M[0], height, TABLE_SIZE_M[1])
        self.sphere_center = np.array([x + 0.17, self.table_top + SPHERE_RADIUS_M, z + 0.05])
        tilt = math.radians(PANEL_TILT_DEG)
        up = np.array([0.0, math.cos(tilt), -math.sin(tilt)])
        back = z - TABLE_SIZE_M[1] / 2 + 0.05
        center = np.array([x - 0.08, self.table_top + 0.02 + PANEL_SIZE_M[1] / 2 * up[1], back])
        self.panel = PanelFrame(center, np.array([1.0, 0.0, 0.0]), up, PANEL_SIZE_M)
        self.hovered: dict[str, str | None] = {}
        self._ctx = None

    def sand_objects(self) -> list[tuple[dict, np.ndarray]]:
        """(mesh, origin) of the sand-covered objects: the block and the sphere."""
        return [
            (box_mesh(self.table_center, self.table_size, self.table_center), self.table_center),
            (sphere_mesh(self.sphere_center, SPHERE_RADIUS_M, 48, self.sphere_center),
             self.sphere_center),
        ]  # fmt: skip

    # ---- pointing --------------------------------------------------------------------------

    def aim(self, hand: str, pose) -> tuple[float, float, float] | None:
        """Update what ``hand`` points at (None: nothing); returns the panel hit."""
        hit = None if pose is None else self.panel.hit(pose.position, pose.forward)
        self.hovered[hand] = None if hit is None else button_at(hit[0], hit[1])
        return hit

    def press(self, hand: str) -> Command | None:
        """The command of the button ``hand`` points at, if any."""
        name = self.hovered.get(hand)
        return None if name is None else BUTTONS[name][5]

    # ---- drawing ---------------------------------------------------------------------------

    def panel_text(self, state: ViewState, preset_name: str) -> tuple:
        """What the panel shows: it is drawn again only when this changes."""
        return (
            format_time(state.hours),
            "playing" if state.playing else "paused",
            _speed_text(state.day_speed),
            f"sand: {preset_name}",
            f"mode: {state.mode}",
            "pause" if state.playing else "play",
            tuple(sorted(name for name in self.hovered.values() if name)),
        )

    def panel_image(self, state: ViewState, preset_name: str) -> Image.Image:
        """The panel as an RGB image (top row first)."""
        clock, state, speed, sand, mode, play, hovered = self.panel_text(state, preset_name)
        width, height = PANEL_PIXELS
        image = Image.new("RGB", PANEL_PIXELS, (28, 24, 20))
        draw = ImageDraw.Draw(image)
        big, small, label_font = _font(96), _font(40), _font(24)
        text_colour = (230, 220, 200)
        draw.text((28, 12), clock, font=big, fill=(255, 236, 200))
        draw.text((330, 24), state, font=small, fill=text_colour)
        draw.text((330, 70), speed, font=small, fill=text_colour)
        draw.text((28, 150), sand, font=small, fill=text_colour)
        draw.text((28, 205), mode, font=small, fill=text_colour)
        for name, (u0, v0, u1, v1, label, _command) in BUTTONS.items():
            label = play if name == "play" else label
            box = (u0 * width, (1 - v1) * height, u1 * width, (1 - v0) * height)
            fill = (214, 160, 80) if name in hovered else (70, 60, 50)
            draw.rounded_rectangle(box, radius=10, fill=fill, outline=(150, 130, 100), width=2)
            left = (box[0] + box[2] - draw.textlength(label, font=label_font)) / 2
            draw.text((left, box[1] + 20), label, font=label_font, fill=(255, 255, 255))
        return image

    def draw(
        self,
        ctx: moderngl.Context,
        camera: Camera,
        viewport: tuple[int, int, int, int],
        state: ViewState,
        preset_name: str,
        rays: list,
    ) -> None:
        """Panel and ``rays`` (poses of aiming hands) over the image already in the bound
        framebuffer's ``viewport``."""
        if self._ctx is None:
            self._create(ctx)
        key = self.panel_text(state, preset_name)
        if key != self._panel_key:
            image = self.panel_image(state, preset_name).transpose(Image.FLIP_TOP_BOTTOM)
            self._texture.write(image.tobytes())
            self._texture.build_mipmaps()
            self._panel_key = key
        ctx.viewport = viewport
        with render_state(ctx):
            self._draw_overlay(camera, rays)

    def _draw_overlay(self, camera: Camera, rays) -> None:
        prog = self._program
        set_matrix(prog, "u_view_projection", camera.projection @ camera.view)
        prog["u_textured"].value = True
        self._texture.use(location=0)
        prog["u_panel"].value = 0
        self._panel_vao.render(moderngl.TRIANGLE_FAN)
        prog["u_textured"].value = False
        for pose in rays:
            if pose is None:
                continue
            hit = self.panel.hit(pose.position, pose.forward)
            length = hit[2] if hit else RAY_LENGTH_M
            start = np.asarray(pose.position)
            end = start + pose.forward * length
            self._ray_buffer.write(np.array([*start, 0, 0, *end, 0, 0], np.float32).tobytes())
            prog["u_colour"].value = (1.0, 0.85, 0.4, 1.0) if hit else (0.8, 0.8, 0.9, 1.0)
            self._ray_vao.render(moderngl.LINES)

    def _create(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        self._owned = GLObjects()
        keep = self._owned.keep
        self._program = keep(program(ctx, "vr_overlay.glsl"))
        corners = self.panel.corners()
        uv = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], float)
        vertices = np.hstack([corners, uv]).astype(np.float32)
        self._panel_buffer = keep(ctx.buffer(vertices.tobytes()))
        self._panel_vao = keep(
            ctx.vertex_array(self._program, [(self._panel_buffer, "3f 2f", "a_position", "a_uv")])
        )
        self._ray_buffer = keep(ctx.buffer(reserve=2 * 5 * 4))
        self._ray_vao = keep(
            ctx.vertex_array(self._program, [(self._ray_buffer, "3f 2x4", "a_position")])
        )
        self._texture = keep(ctx.texture(PANEL_PIXELS, 3))
        self._texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        self._panel_key = None

    def release(self) -> None:
        if self._ctx is None:
            return
        self._owned.release()
        self._ctx = None


def _speed_text(speed: float) -> str:
    if speed <= 0:
        return "clock stopped"
    if speed < 0.1:
        return f"{speed * 60:.2g} min/s"
    return f"{speed:.2g} h/s"


_FONTS: dict[int, ImageFont.ImageFont] = {}


def _font(size: int):
    if size not in _FONTS:
        _FONTS[size] = ImageFont.load_default(size=size)
    return _FONTS[size]
