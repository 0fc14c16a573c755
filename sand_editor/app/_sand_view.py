"""The 3D view's GL widget: the desert drawn by the one renderer (``sand_editor.render``) into a
QOpenGLWidget, at reduced resolution while anything changes and refined in bands at rest."""

from __future__ import annotations

import math
import time

import moderngl
import shiboken6
from PySide6.QtCore import QPointF, Qt, QTimer, Signal
from PySide6.QtGui import QOffscreenSurface, QOpenGLContext
from PySide6.QtOpenGLWidgets import QOpenGLWidget
from PySide6.QtWidgets import QWidget

from sand_editor.app._gl_resources import GLResources, surface_format
from sand_editor.app._refinement import (
    FRAME_BUDGET_MS,
    MIN_BAND_ROWS,
    SETTLE_MS,
    adapted_scale,
    band_camera,
)
from sand_editor.generator import SandTextures
from sand_editor.gl import (
    REQUIRED_GL_VERSION,
    draw_fullscreen,
    drawing_into,
    finish_without_gil,
    fullscreen_program,
    release_standalone_context,
)
from sand_editor.preset import Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at

WHEEL_FACTOR = 1.15
DEG_PER_PIXEL = 0.3


class SandView(QOpenGLWidget):
    """Draws one frame on demand; all GL work happens with this widget's context current.

    The grains come from the editor's one generation (``set_grains``); the view uploads them
    the next time it draws, so a hidden view does no work for an edit. While the camera, the
    clock or the preset is changing, frames are drawn at reduced resolution (``scale``), and
    ``SETTLE_MS`` after the last change once more at full resolution.

    Signals
    -------
    orbited(float, float)
        A left-button drag: degrees of heading and pitch to add.
    zoomed(float)
        A wheel turn: the factor to multiply the distance by.
    rendered(dict)
        A frame was drawn: the renderer's timings plus ``total_ms`` (CPU and GPU, the frame
        finished) and ``scale`` (the fraction of the widget's pixels along each side).
    failed(str)
        The view cannot draw (no suitable context, or initialisation raised).
    """

    orbited = Signal(float, float)
    zoomed = Signal(float)
    rendered = Signal(object)
    failed = Signal(str)

    def __init__(self, preset: Preset, parent: QWidget | None = None):
        super().__init__(parent)
        self.setFormat(surface_format())
        self.setMinimumSize(160, 100)
        self.gl = GLResources()
        self.error: str | None = None
        self.last_timings: dict | None = None
        self.frames = 0
        self.full_frames = 0  # frames drawn at full resolution
        self.grain_uploads = 0  # tiles uploaded into the material
        self.distance_m = 1.0
        self.pitch_deg = 45.0
        self.heading_deg = 0.0
        self.time_hours = 10.0
        self.mode = "full"
        self.show_sphere = False
        self.exposure: float | None = None  # None: metered and adapted, as an eye does
        self._band_exposure: float | None = None
        self.moving_scale = 0.5
        self._preset = preset
        self._pending_grains: SandTextures | None = None
        self._material_stale = True
        self._moving = False
        self._refined_rows = 0  # rows of the full-resolution frame drawn since the last change
        self._refined_size = (0, 0)
        self._pixel_ms = 0.002  # what a pixel costs, measured on every frame
        self._refine_ms, self._bands = 0.0, 0
        self._frame_end = 0.0
        self._frame_ms = 0.0
        self._frame_timer = QTimer(self, singleShot=True)
        self._frame_timer.timeout.connect(self.update)
        self._settle = QTimer(self, singleShot=True, interval=SETTLE_MS)
        self._settle.timeout.connect(self._settled)
        self._drag_from: QPointF | None = None

    @property
    def ctx(self) -> moderngl.Context | None:
        return self.gl.ctx

    @property
    def material(self) -> SandMaterial | None:
        return self.gl.material

    @property
    def renderer(self) -> SandRenderer | None:
        return self.gl.renderer

    @property
    def grains_generation(self):
        """The generation parameters of the grains the view draws with (None before any)."""
        material = self.gl.material
        return None if material is None else material.grains_generation

    @property
    def at_rest(self) -> bool:
        """Nothing is changing and the full-resolution frame is complete."""
        return (
            not self._moving
            and self.last_timings is not None
            and self.last_timings["refined"] == 1.0
        )

    # -- state -----------------------------------------------------------------------------------

    def set_view(self, **values) -> None:
        """Set distance_m, pitch_deg, heading_deg, time_hours, mode, show_sphere or exposure."""
        for name, value in values.items():
            if not hasattr(self, name):
                raise AttributeError(name)
            setattr(self, name, value)
        self.changing()

    def set_preset(self, preset: Preset) -> None:
        shading_changed = preset.shading != self._preset.shading
        self._preset = preset
        self._material_stale = True
        if shading_changed or preset.generation == self.grains_generation:
            self.changing()
        # else only the generation changed: the view redraws when its tile arrives, never
        # before with the grains it has.

    def set_grains(self, textures: SandTextures) -> None:
        """A full tile from the editor's generation (it names its own), uploaded when next
        drawn."""
        self._pending_grains = textures
        self._material_stale = True
        self.changing()

    def changing(self) -> None:
        """Something in view changes: draw at reduced resolution until it settles."""
        self._moving = True
        self._refined_rows = 0
        self._settle.start()
        self._request_frame()

    def _request_frame(self) -> None:
        # After a frame the event loop gets at least as long again to itself: input and
        # timers wait for at most one frame, never for a queue of them.
        wait_ms = (self._frame_end + self._frame_ms / 1e3 - time.perf_counter()) * 1e3
        if wait_ms <= 0:
            self.update()
        elif not self._frame_timer.isActive():
            self._frame_timer.start(math.ceil(wait_ms))

    def _settled(self) -> None:
        self._moving = False
        self._request_frame()

    def _fail(self, message: str) -> None:
        self.error = message
        self.failed.emit(message)

    # -- GL ----------------------------------------------------------------------------------------

    def initializeGL(self) -> None:
        fmt = self.context().format()
        version = fmt.majorVersion() * 100 + fmt.minorVersion() * 10
        if version < REQUIRED_GL_VERSION:
            self._fail(
                f"The 3D view needs OpenGL 3.3; this display offers "
                f"{fmt.majorVersion()}.{fmt.minorVersion()}."
            )
            return
        release_standalone_context()  # Qt's context and an EGL one cannot both be current
        gl = self.gl
        try:
            gl.ctx = moderngl.create_context()
            gl.renderer = SandRenderer(gl.ctx)
            gl.renderer.exposure.adapt_over_time = True
            gl.upscale = fullscreen_program(gl.ctx, "upscale.frag")
        except Exception as error:
            self._fail(f"Cannot start the 3D view: {error}")
            return
        # Where the context must be made current while the widget is being destroyed. Owned
        # by the widget, so it outlives the context's destruction (the widget's children go
        # last), whatever Python collects first at exit.
        gl.surface = QOffscreenSurface(None, self)
        gl.surface.setFormat(self.context().format())
        gl.surface.create()
        # Not a slot of the widget, nor using the context's wrapper: this runs from their
        # destructors, when PySide already counts both as deleted; a fresh wrapper of the
        # context (still valid in C++ until the signal returns) can make it current.
        address = shiboken6.getCppPointer(self.context())[0]
        self.context().aboutToBeDestroyed.connect(
            lambda: gl.release(shiboken6.wrapInstance(address, QOpenGLContext))
        )

    def _sync_material(self) -> None:
        """Upload a new tile, or follow a shading change, in the material (context current)."""
        gl = self.gl
        # Qt leaves its own state behind (blending, for one): the material's passes start
        # from none.
        gl.ctx.enable_only(moderngl.NOTHING)
        if self._pending_grains is not None:
            textures, self._pending_grains = self._pending_grains, None
            if gl.material is None or gl.material.texture_size != textures.size:
                if gl.material is not None:
                    gl.material.release()
                gl.material = SandMaterial(gl.ctx, textures.size)
                gl.renderer.set_material(gl.material)
            gl.material.update(self._preset, grains=textures)
            self.grain_uploads += 1
        elif self._material_stale and gl.material is not None:
            if self._preset.generation != gl.material.grains_generation:
                return  # the view never makes grains: the edit shows with its tile
            gl.material.update(self._preset)
        self._material_stale = False

    def paintGL(self) -> None:
        if self.renderer is None or self.error is not None:
            return
        start = time.perf_counter()
        try:
            self._sync_material()
        except Exception as error:  # a driver error is shown, not fatal to the editor
            self._fail(f"3D view: {error}")
            return
        if self.material is None:
            return  # the first tile is still being generated
        ratio = self.devicePixelRatioF()
        size = (max(1, round(self.width() * ratio)), max(1, round(self.height() * ratio)))
        try:
            screen = self.ctx.detect_framebuffer(self.defaultFramebufferObject())
            camera = self._camera(size)
            timings = None
            fresh = self._refined_rows == 0 or size != self._refined_size
            if self._moving or fresh or "moving" not in self.gl.targets:
                timings = self._draw_moving(camera, size)
                self._refined_rows, self._refined_size = 0, size
            if not self._moving:
                timings = self._refine(camera, size) or timings
            self._show(screen, size)
            # Qt's framebuffer stays bound after the paint, as on entry: Qt discards its
            # depth and stencil after paintGL, an error on any other framebuffer.
            screen.use()
            # The frame's whole cost, not only the CPU's share of it; the generator's thread
            # queues its next band meanwhile.
            finish_without_gil()
        except Exception as error:
            self._fail(f"3D view: {error}")
            return
        if timings is None:
            return  # an expose: the finished frame shown again
        self._frame_end = time.perf_counter()
        self._frame_ms = timings["total_ms"] = (self._frame_end - start) * 1e3
        if timings["scale"] < 1.0:
            self._adapt_scale(timings["total_ms"], timings["scale"])
        self.frames += 1
        self.full_frames += timings["refined"] == 1.0
        self.last_timings = timings
        self.rendered.emit(timings)
        if timings["refined"] < 1.0 and not self._moving:
            self._request_frame()  # the next band

    def _camera(self, size: tuple[int, int]):
        terrain = self.renderer.terrain
        return camera_at_distance(
            self.distance_m,
            self.pitch_deg,
            size[0] / size[1],
            ground_height=lambda x, z: float(terrain.height(x, z)),
            heading_deg=self.heading_deg,
        )

    def _render(self, target, camera, viewport, exposure=None, moving=False) -> dict:
        return self.renderer.render(
            target,
            FrameRequest(
                camera,
                sky_at(self.time_hours),
                self.mode,
                viewport=viewport,
                exposure=self.exposure if exposure is None else exposure,
                show_sphere=self.show_sphere,
                moving=moving,
            ),
        )

    def _draw_moving(self, camera, size: tuple[int, int]) -> dict:
        scale = self.moving_scale
        low = (max(1, round(size[0] * scale)), max(1, round(size[1] * scale)))
        start = time.perf_counter()
        target = self.gl.target("moving", *low)
        timings = self._render(target, camera, (0, 0, *low), moving=self._moving)
        self._band_exposure = timings["exposure"]  # metered band by band, each would differ
        finish_without_gil()
        self._pixel_ms = (time.perf_counter() - start) * 1e3 / (low[0] * low[1])
        timings.update(scale=scale, refined=0.0)
        return timings

    def _refine(self, camera, size: tuple[int, int]) -> dict | None:
        """Draw the next band of rows of the full-resolution frame; None when it is complete.

        Each band is a frame of its own through the matching slice of the camera's frustum,
        sized to take about ``FRAME_BUDGET_MS``, so the event loop runs between bands.
        """
        width, height = size
        full = self.gl.target("full", width, height)
        if self._refined_rows >= height:
            return None
        rows = int(FRAME_BUDGET_MS / max(self._pixel_ms * width, 1e-6))
        rows = min(max(rows, MIN_BAND_ROWS), height - self._refined_rows)
        first = self._refined_rows
        if first == 0:
            self._refine_ms, self._bands = 0.0, 0
        band = band_camera(camera, first, first + rows, height)
        start = time.perf_counter()
        timings = self._render(full, band, (0, first, width, rows), self._band_exposure)
        finish_without_gil()
        self._pixel_ms = (time.perf_counter() - start) * 1e3 / (width * rows)
        self._refined_rows = first + rows
        self._refine_ms += (time.perf_counter() - start) * 1e3
        self._bands += 1
        timings.update(
            scale=1.0,
            refined=self._refined_rows / height,
            refine_ms=self._refine_ms,
            bands=self._bands,
        )
        return timings

    def _show(self, screen, size: tuple[int, int]) -> None:
        """The reduced frame scaled up, with the rows refined so far over it."""
        moving = self.gl.targets.get("moving")
        if moving is not None:
            self._draw_target(moving, screen, size, size[1])
        if not self._moving and self._refined_rows > 0 and "full" in self.gl.targets:
            self._draw_target(self.gl.targets["full"], screen, size, self._refined_rows)

    def _draw_target(self, source, screen, size: tuple[int, int], rows: int) -> None:
        program = self.gl.upscale
        source.color_attachments[0].use(location=0)
        program["u_source"].value = 0
        program["u_size"].value = tuple(float(v) for v in size)
        with drawing_into(self.ctx, screen):
            # The viewport covers the whole widget (so the shader's coordinates do); the
            # scissor keeps the rows wanted.
            self.ctx.viewport = (0, 0, *size)
            self.ctx.scissor = (0, 0, size[0], rows)
            try:
                draw_fullscreen(self.ctx, program)
            finally:
                self.ctx.scissor = None

    def _adapt_scale(self, frame_ms: float, scale: float) -> None:
        self.moving_scale = adapted_scale(frame_ms, scale)

    def cleanup(self) -> None:
        """Release our GL objects now (the view then stays blank)."""
        self.gl.release(self.context())

    # -- mouse -------------------------------------------------------------------------------------

    def mousePressEvent(self, event) -> None:
        if event.button() == Qt.MouseButton.LeftButton:
            self._drag_from = event.position()
        super().mousePressEvent(event)

    def mouseMoveEvent(self, event) -> None:
        if self._drag_from is not None:
            delta = event.position() - self._drag_from
            self._drag_from = event.position()
            self.orbited.emit(delta.x() * DEG_PER_PIXEL, delta.y() * DEG_PER_PIXEL)
        super().mouseMoveEvent(event)

    def mouseReleaseEvent(self, event) -> None:
        if event.button() == Qt.MouseButton.LeftButton:
            self._drag_from = None
        super().mouseReleaseEvent(event)

    def wheelEvent(self, event) -> None:
        steps = event.angleDelta().y() / 120.0
        if steps:
            # Wheel forward moves closer.
            self.zoomed.emit(WHEEL_FACTOR ** (-steps))
        event.accept()
