"""The workbench's GL side: the desk, tray walls and controller bodies in the HDR scene
(``shaders/vr_props.glsl``), and over the finished eye image the panel, the rays, the teleport
arc (``shaders/vr_overlay.glsl``, depth-tested against the scene) and the comfort vignette
(``shaders/vr_vignette.frag``)."""

from __future__ import annotations

import moderngl
import numpy as np

from sand_editor.gl import (
    GLObjects,
    draw_fullscreen,
    fullscreen_program,
    program,
    render_state,
    set_matrix,
    set_uniform,
)
from sand_editor.render.camera import Camera
from sand_editor.render.shadows import SHADER_DEFINES as SHADOW_DEFINES

ARC_WIDTH_M = 0.012  # the teleport arc's ribbon, across
LANDING_RADIUS_M = 0.3
LANDING_SEGMENTS = 32
ARC_VALID = (0.35, 0.85, 1.0, 1.0)
ARC_REFUSED = (1.0, 0.3, 0.25, 1.0)
RAY = (0.8, 0.8, 0.9, 1.0)
RAY_ON_PANEL = (1.0, 0.85, 0.4, 1.0)
_MAX_PROP_ROWS = 4096
_MAX_STRIP = 1024


class BenchGraphics:
    """GL objects of the workbench, made on ``ctx``; ``release`` frees them all."""

    def __init__(self, ctx: moderngl.Context, panel_pixels: tuple[int, int]) -> None:
        self.ctx = ctx
        self._owned = GLObjects()
        keep = self._owned.keep
        self._props = keep(program(ctx, "vr_props.glsl", SHADOW_DEFINES))
        self._overlay = keep(program(ctx, "vr_overlay.glsl"))
        self._vignette = keep(fullscreen_program(ctx, "vr_vignette.frag"))
        self._fixed = keep(ctx.buffer(reserve=_MAX_PROP_ROWS * 36))
        self._fixed_rows = 0
        self._moving = keep(ctx.buffer(reserve=_MAX_PROP_ROWS * 36))
        layout = (("3f 3f 3f", "a_position", "a_normal", "a_albedo"),)
        self._fixed_vao = keep(ctx.vertex_array(self._props, [(self._fixed, *layout[0])]))
        self._moving_vao = keep(ctx.vertex_array(self._props, [(self._moving, *layout[0])]))
        self._panel_buffer = keep(ctx.buffer(reserve=4 * 5 * 4))
        self._panel_vao = keep(
            ctx.vertex_array(self._overlay, [(self._panel_buffer, "3f 2f", "a_position", "a_uv")])
        )
        self._strip = keep(ctx.buffer(reserve=_MAX_STRIP * 5 * 4))
        self._strip_vao = keep(
            ctx.vertex_array(self._overlay, [(self._strip, "3f 2x4", "a_position")])
        )
        self.panel_texture = keep(ctx.texture(panel_pixels, 3))
        self.panel_texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        self.panel_texture.anisotropy = 8.0
        self.origin = np.zeros(3)

    # ---- what is drawn ------------------------------------------------------------------------

    def set_fixed(self, rows: np.ndarray, origin) -> None:
        """The props that stay put (the desk), world positions; drawn relative to ``origin``."""
        self.origin = np.asarray(origin, dtype=np.float64)
        rows = _relative(rows, self.origin)[:_MAX_PROP_ROWS]
        self._fixed.write(rows.tobytes())
        self._fixed_rows = len(rows)

    def set_panel(self, corners: np.ndarray) -> None:
        uv = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], float)
        self._panel_buffer.write(np.hstack([corners, uv]).astype(np.float32).tobytes())

    # ---- in the HDR scene ---------------------------------------------------------------------

    def draw_props(self, camera: Camera, sky, moving: np.ndarray | None, shadows=None) -> None:
        """The desk and ``moving`` props (controllers; world positions) lit by ``sky`` and
        shadowed by ``shadows`` (the renderer's ``SceneShadows``; None: unshadowed), into the
        bound scene framebuffer (the renderer's depth test is on)."""
        prog = self._props
        for name in ("sun_direction", "sun_radiance", "moon_direction", "moon_radiance",
                     "sky_irradiance"):  # fmt: skip
            set_uniform(prog, f"u_{name}", tuple(float(v) for v in getattr(sky, name)))
        set_uniform(prog, "u_eye", tuple(float(v) for v in camera.position))
        set_uniform(prog, "u_origin", tuple(float(v) for v in self.origin))
        if shadows is None:
            set_uniform(prog, "u_shadow_cascades", 0)
        else:
            shadows.bind(prog, self.origin)
        view_projection = camera.projection.astype(np.float64) @ camera.view_relative_to(
            self.origin
        )
        set_matrix(prog, "u_view_projection", view_projection)
        self.ctx.enable(moderngl.CULL_FACE)
        try:
            if self._fixed_rows:
                self._fixed_vao.render(moderngl.TRIANGLES, vertices=self._fixed_rows)
            if moving is not None and len(moving):
                rows = _relative(moving, self.origin)[:_MAX_PROP_ROWS]
                self._moving.write(rows.tobytes())
                self._moving_vao.render(moderngl.TRIANGLES, vertices=len(rows))
        finally:
            self.ctx.disable(moderngl.CULL_FACE)

    # ---- over the finished image --------------------------------------------------------------

    def draw_overlay(self, camera: Camera, rays, aim) -> None:
        """The panel, ``rays`` ((start, end, hit) in the world) and the teleport ``aim``
        (``locomotion.Aim`` or None), depth-tested against the bound framebuffer's depth."""
        prog = self._overlay
        set_matrix(prog, "u_view_projection", camera.projection @ camera.view)
        with render_state(self.ctx, moderngl.DEPTH_TEST):
            prog["u_textured"].value = True
            self.panel_texture.use(location=0)
            prog["u_panel"].value = 0
            self._panel_vao.render(moderngl.TRIANGLE_FAN)
            prog["u_textured"].value = False
            for start, end, hit in rays:
                colour = RAY_ON_PANEL if hit else RAY
                self._draw_strip(np.array([start, end]), moderngl.LINES, colour)
            if aim is not None:
                colour = ARC_VALID if aim.valid else ARC_REFUSED
                ribbon = arc_ribbon(aim.points, camera.eye, ARC_WIDTH_M)
                self._draw_strip(ribbon, moderngl.TRIANGLE_STRIP, colour)
                if aim.target is not None:
                    self._draw_strip(landing_ring(aim.target), moderngl.TRIANGLE_STRIP, colour)

    def draw_vignette(self, viewport, strength: float) -> None:
        """Darken the edges of ``viewport`` by ``strength`` (0: nothing is drawn)."""
        if strength <= 0.0:
            return
        set_uniform(self._vignette, "u_viewport", tuple(float(v) for v in viewport))
        set_uniform(self._vignette, "u_strength", float(min(strength, 1.0)))
        blend = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
        with render_state(self.ctx, moderngl.BLEND, blend_func=blend):
            draw_fullscreen(self.ctx, self._vignette, blend=True)

    def _draw_strip(self, points: np.ndarray, mode: int, colour) -> None:
        points = np.asarray(points, np.float32)[:_MAX_STRIP]
        if len(points) < 2 or not np.all(np.isfinite(points)):
            return
        rows = np.hstack([points, np.zeros((len(points), 2), np.float32)])
        self._strip.write(rows.tobytes())
        self._overlay["u_colour"].value = tuple(colour)
        self._strip_vao.render(mode, vertices=len(points))

    def release(self) -> None:
        self._owned.release()


def arc_ribbon(points: np.ndarray, eye, width: float) -> np.ndarray:
    """A triangle strip ``width`` across along ``points``, turned to face ``eye``: a line of
    constant width in the world, which a headset's single-pixel lines are not."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 2:
        return np.zeros((0, 3))
    along = np.gradient(points, axis=0)
    to_eye = np.asarray(eye, dtype=np.float64) - points
    side = np.cross(along, to_eye)
    length = np.linalg.norm(side, axis=1, keepdims=True)
    side = np.where(length > 1e-12, side / np.maximum(length, 1e-12), (1.0, 0.0, 0.0))
    # Wider further from the eye, so the far end of a long throw still reads.
    distance = np.linalg.norm(to_eye, axis=1, keepdims=True)
    half = 0.5 * width * np.maximum(1.0, distance / 2.0) * side
    strip = np.empty((2 * len(points), 3))
    strip[0::2], strip[1::2] = points - half, points + half
    return strip


def landing_ring(center, radius: float = LANDING_RADIUS_M, thickness: float = 0.04) -> np.ndarray:
    """A flat ring on the ground around ``center`` (a triangle strip), lifted a centimetre."""
    angles = np.linspace(0.0, 2 * np.pi, LANDING_SEGMENTS + 1)
    ring = np.stack([np.cos(angles), np.zeros_like(angles), np.sin(angles)], axis=1)
    center = np.asarray(center, dtype=np.float64) + (0.0, 0.01, 0.0)
    strip = np.empty((2 * len(angles), 3))
    strip[0::2] = center + ring * (radius - thickness)
    strip[1::2] = center + ring * radius
    return strip


def _relative(rows: np.ndarray, origin: np.ndarray) -> np.ndarray:
    rows = np.array(rows, dtype=np.float64)
    rows[:, :3] -= origin
    return rows.astype(np.float32)
