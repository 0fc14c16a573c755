"""The workbench: a desk at hand height with a tray of the sand being edited and a sand sphere
on it, and a panel at its back showing the time, day speed, sand and mode, with buttons pressed
by aiming a controller ray at them and pulling the trigger. It stands in front of the user, and
can be brought along (``Workbench(..., stand_xz, yaw)`` again) after a teleport.

The shapes are ``bench_meshes``'; the GL drawing is ``bench_draw``'s."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sand_editor.render.camera import Camera
from sand_editor.view import ViewState, format_time
from sand_editor.vr.actions import Command, CommandKind
from sand_editor.vr.bench_draw import BenchGraphics
from sand_editor.vr.bench_meshes import DESK_SIZE_M, DeskLayout

PANEL_SIZE_M = (0.48, 0.27)
PANEL_TILT_DEG = 25.0  # leaning back, towards the sky
PANEL_PIXELS = (1024, 576)  # about 2100 pixels per metre: sharp at a headset's 20–25 px/°
PANEL_OFFSET_M = (-0.05, -0.24)  # its lower edge's middle from the desk top's (x, z)
RAY_LENGTH_M = 3.0


@dataclass(frozen=True)
class PanelButton:
    """A button on the panel: its ``box`` in panel coordinates (u0, v0, u1, v1; u right, v up,
    0..1), its ``label`` and the ``command`` a press runs."""

    name: str
    label: str
    command: Command
    box: tuple[float, float, float, float]

    def contains(self, u: float, v: float) -> bool:
        u0, v0, u1, v1 = self.box
        return u0 <= u <= u1 and v0 <= v <= v1


# One row along the panel's bottom edge.
_BUTTON_ROW = [
    ("earlier", "-1 h", Command(CommandKind.SCRUB, -1.0)),
    ("later", "+1 h", Command(CommandKind.SCRUB, 1.0)),
    ("play", "play", Command(CommandKind.PLAY_PAUSE)),
    ("slower", "slower", Command(CommandKind.SPEED_STEP, -1)),
    ("faster", "faster", Command(CommandKind.SPEED_STEP, 1)),
    ("sand", "sand >", Command(CommandKind.NEXT_PRESET)),
    ("lambert", "Lambert", Command(CommandKind.TOGGLE_LAMBERT)),
    ("comfort", "vignette", Command(CommandKind.TOGGLE_COMFORT)),
]
_ROW_V = (0.04, 0.21)
_ROW_U = (0.015, 0.985)
_GAP_U = 0.008
_WIDTH_U = (_ROW_U[1] - _ROW_U[0] - _GAP_U * (len(_BUTTON_ROW) - 1)) / len(_BUTTON_ROW)
BUTTONS = {
    name: PanelButton(
        name,
        label,
        command,
        (
            _ROW_U[0] + i * (_WIDTH_U + _GAP_U),
            _ROW_V[0],
            _ROW_U[0] + i * (_WIDTH_U + _GAP_U) + _WIDTH_U,
            _ROW_V[1],
        ),
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
    return next((name for name, button in BUTTONS.items() if button.contains(u, v)), None)


class Workbench:
    """The desk for a user standing at ``stand_xz`` facing ``yaw`` (radians about +y, 0 looks
    along −z) on ground ``ground_height(x, z)``: its sand objects for the renderer, the panel
    and what each hand points at, and its drawing."""

    def __init__(self, ground_height, stand_xz=(0.0, 0.0), yaw: float = 0.0) -> None:
        self.layout = DeskLayout(ground_height, stand_xz, yaw)
        self.ground_height = ground_height
        self.table_top = self.layout.top
        rotation = self.layout.rotation
        tilt = math.radians(PANEL_TILT_DEG)
        up = rotation @ np.array([0.0, math.cos(tilt), -math.sin(tilt)])
        edge = self.layout.on_desk(PANEL_OFFSET_M[0], PANEL_OFFSET_M[1], 0.015)
        center = edge + up * PANEL_SIZE_M[1] / 2
        self.panel = PanelFrame(center, rotation @ np.array([1.0, 0.0, 0.0]), up, PANEL_SIZE_M)
        self.hovered: dict[str, str | None] = {}
        self._graphics: BenchGraphics | None = None
        self._panel_key = None

    def sand_objects(self) -> list[tuple[dict, np.ndarray]]:
        """(mesh, origin) of the sand-covered objects: the sand in the tray and the sphere."""
        return self.layout.sand_objects()

    def contains(self, point) -> bool:
        """Whether ``point`` (world) lies over the desk: no teleporting into it."""
        local = self.layout.rotation.T @ (np.asarray(point, float) - self.layout.origin)
        return abs(local[0]) <= DESK_SIZE_M[0] / 2 and abs(local[2]) <= DESK_SIZE_M[2] / 2

    # ---- pointing --------------------------------------------------------------------------

    def aim(self, hand: str, pose) -> tuple[float, float, float] | None:
        """Update what ``hand`` points at (None: nothing); returns the panel hit."""
        hit = None if pose is None else self.panel.hit(pose.position, pose.forward)
        self.hovered[hand] = None if hit is None else button_at(hit[0], hit[1])
        return hit

    def press(self, hand: str) -> Command | None:
        """The command of the button ``hand`` points at, if any."""
        name = self.hovered.get(hand)
        return None if name is None else BUTTONS[name].command

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
        k = width / 768  # the layout is drawn for 768 pixels across
        image = Image.new("RGB", PANEL_PIXELS, (28, 24, 20))
        draw = ImageDraw.Draw(image)
        big, small, label_font = _font(round(96 * k)), _font(round(40 * k)), _font(round(24 * k))
        text_colour = (230, 220, 200)
        draw.text((28 * k, 12 * k), clock, font=big, fill=(255, 236, 200))
        draw.text((330 * k, 24 * k), state, font=small, fill=text_colour)
        draw.text((330 * k, 70 * k), speed, font=small, fill=text_colour)
        draw.text((28 * k, 150 * k), sand, font=small, fill=text_colour)
        draw.text((28 * k, 205 * k), mode, font=small, fill=text_colour)
        for name, button in BUTTONS.items():
            label = play if name == "play" else button.label
            u0, v0, u1, v1 = button.box
            box = (u0 * width, (1 - v1) * height, u1 * width, (1 - v0) * height)
            fill = (214, 160, 80) if name in hovered else (70, 60, 50)
            draw.rounded_rectangle(box, radius=10 * k, fill=fill, outline=(150, 130, 100),
                                   width=round(2 * k))  # fmt: skip
            left = (box[0] + box[2] - draw.textlength(label, font=label_font)) / 2
            draw.text((left, box[1] + 20 * k), label, font=label_font, fill=(255, 255, 255))
        return image

    def draw_props(self, ctx: moderngl.Context, camera: Camera, sky, moving=None,
                   shadows=None) -> None:  # fmt: skip
        """The desk, the tray's walls and the ``moving`` props (the controllers' bodies,
        ``bench_meshes.controller_props`` rows, world positions) into the renderer's HDR
        scene, in the renderer's ``shadows``."""
        self._gl(ctx).draw_props(camera, sky, moving, shadows)

    def draw(self, ctx: moderngl.Context, camera: Camera, viewport, state: ViewState,
             preset_name: str, rays: list, aim=None) -> None:  # fmt: skip
        """Panel, ``rays`` (poses of aiming hands) and the teleport ``aim`` over the image (and
        depth) already in the bound framebuffer's ``viewport``."""
        graphics = self._gl(ctx)
        key = self.panel_text(state, preset_name)
        if key != self._panel_key:
            image = self.panel_image(state, preset_name).transpose(Image.FLIP_TOP_BOTTOM)
            graphics.panel_texture.write(image.tobytes())
            graphics.panel_texture.build_mipmaps()
            self._panel_key = key
        ctx.viewport = viewport
        segments = []
        for pose in rays:
            if pose is None:
                continue
            hit = self.panel.hit(pose.position, pose.forward)
            start = np.asarray(pose.position)
            segments.append((start, start + pose.forward * (hit[2] if hit else RAY_LENGTH_M), hit))
        graphics.draw_overlay(camera, segments, aim)

    def draw_vignette(self, ctx: moderngl.Context, viewport, strength: float) -> None:
        self._gl(ctx).draw_vignette(viewport, strength)

    def _gl(self, ctx: moderngl.Context) -> BenchGraphics:
        if self._graphics is None:
            self._graphics = BenchGraphics(ctx, PANEL_PIXELS)
            self._graphics.set_fixed(self.layout.props(), self.layout.origin)
            self._graphics.set_panel(self.panel.corners())
            self._panel_key = None
        return self._graphics

    def release(self) -> None:
        if self._graphics is not None:
            self._graphics.release()
            self._graphics = None


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
