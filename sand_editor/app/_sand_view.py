"""The 3D view's widget: the desert drawn by the one renderer (``sand_editor.render``) on a
thread of its own (``_render_worker``), at reduced resolution while anything changes and refined
in bands at rest; the widget paints what the thread sends back and never waits for it."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, QTimer, Signal
from PySide6.QtGui import QColor, QImage, QPainter
from PySide6.QtWidgets import QWidget

from sand_editor.app._refinement import (
    FRAME_BUDGET_MS,
    MIN_BAND_ROWS,
    SETTLE_MS,
    adapted_scale,
)
from sand_editor.app._render_worker import FrameResult, RenderJob, RenderWorker, ViewParams
from sand_editor.generator import SandTextures
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.still import check_samples

WHEEL_FACTOR = 1.15
DEG_PER_PIXEL = 0.3
_VIEW_FIELDS = frozenset(ViewParams.__dataclass_fields__)


class SandView(QWidget):
    """Shows the frames its drawing thread sends; sends the next job when one comes back.

    The grains come from the editor's one generation (``set_grains``); the view hands them to
    the thread with its next job, so a hidden view does no work for an edit. While the camera,
    the clock or the preset is changing, frames are drawn at reduced resolution (``scale``), and
    ``SETTLE_MS`` after the last change once more at full resolution, in bands of rows: a change
    waits at most for the band in hand. With ``samples`` above 1 the full-resolution frame is
    then drawn again as a still (``SandRenderer.render_still``), one sample of every pixel a
    pass, band by band, each band showing the light its samples have gathered so far.

    Signals
    -------
    orbited(float, float)
        A left-button drag: degrees of heading and pitch to add.
    zoomed(float)
        A wheel turn: the factor to multiply the distance by.
    rendered(dict)
        A frame was drawn: the renderer's timings plus ``total_ms`` (the thread's time for it,
        the frame finished), ``scale`` (the fraction of the widget's pixels along each side) and
        ``refined`` (the share of the full-resolution frame done), ``rows`` (those of it the
        frame brought, from the bottom: a band's, or the whole frame's with the last band of
        the frame or of a still's pass, its light bloomed at once) and, while a still's samples
        are drawn, ``sampled`` (the share of them done) and ``samples``.
    failed(str)
        The view cannot draw (no suitable context, or drawing raised).
    """

    orbited = Signal(float, float)
    zoomed = Signal(float)
    rendered = Signal(object)
    failed = Signal(str)

    def __init__(self, preset: Preset, parent: QWidget | None = None):
        super().__init__(parent)
        self.setMinimumSize(160, 100)
        self.setAttribute(Qt.WidgetAttribute.WA_OpaquePaintEvent)
        self.error: str | None = None
        self.last_timings: dict | None = None
        self.frames = 0
        self.full_frames = 0  # frames completed at full resolution
        self._view = ViewParams()
        self.moving_scale = 0.5
        self._preset = preset
        self._pending_grains: SandTextures | None = None
        self._moving = False
        self._serial = 0  # counts changes: a band drawn before the last one is dropped
        self._in_flight: RenderJob | None = None
        self._wanted = False  # a frame is due once the thread is free (and the view shown)
        self._moving_pixels: np.ndarray | None = None  # the reduced frame, top-down
        self._moving_image: QImage | None = None
        self._full = np.zeros((0, 0, 4), np.uint8)  # the full-resolution frame, top-down
        self._full_image: QImage | None = None
        self._refined_rows = 0  # rows of it (from the bottom) drawn since the last change
        self._band_exposure: float | None = None
        self._pixel_ms = 0.002  # what a pixel costs, measured on every frame
        self._refine_ms, self._bands = 0.0, 0
        self.samples = 1  # samples a pixel on each axis at rest (set_samples)
        self._sample_passes = 0  # samples of every pixel drawn since the last change
        self._sample_rows = 0  # rows (from the bottom) of the pass under way
        self._settle = QTimer(self, singleShot=True, interval=SETTLE_MS)
        self._settle.timeout.connect(self._settled)
        self._drag_from: QPointF | None = None
        self.gl = RenderWorker(self._frame_done)
        # The thread and its GL objects end with the widget (the worker outlives it here).
        worker = self.gl
        self.destroyed.connect(lambda *_: worker.stop())

    @property
    def material(self) -> SandMaterial | None:
        return self.gl.material

    @property
    def renderer(self) -> SandRenderer | None:
        return self.gl.renderer

    @property
    def grain_uploads(self) -> int:
        return self.gl.grain_uploads

    @property
    def grains_generation(self):
        """The generation parameters of the grains the view draws with (None before any)."""
        material = self.gl.material
        return None if material is None else material.grains_generation

    @property
    def at_rest(self) -> bool:
        """Nothing is changing and the full-resolution frame of the current view is shown."""
        return (
            not self._moving
            and not self._wanted
            and self._in_flight is None
            and self.last_timings is not None
            and self.last_timings["refined"] == 1.0
            and not self._samples_left()
        )

    @property
    def view(self) -> ViewParams:
        """What the camera sees now (the view's controls)."""
        return self._view

    @property
    def full_frame(self) -> np.ndarray:
        """The full-resolution frame as drawn so far, rows top-down, RGBA (a copy)."""
        return self._full.copy()

    def call_in_context(self, function):
        """``function(ctx)`` run on the drawing thread with its context current; its value."""
        return self.gl.call(function)

    def gl_error(self) -> str:
        """The (then cleared) error state of the drawing thread's context."""
        return self.call_in_context(lambda ctx: ctx.error)

    # -- state -----------------------------------------------------------------------------------

    def set_view(self, **values) -> None:
        """Set distance_m, pitch_deg, heading_deg, time_hours, mode, show_sphere or exposure."""
        unknown = set(values) - _VIEW_FIELDS
        if unknown:
            raise AttributeError(", ".join(sorted(unknown)))
        self._view = ViewParams(**{**self._view.__dict__, **values})
        self.changing()

    def set_preset(self, preset: Preset) -> None:
        shading_changed = preset.shading != self._preset.shading
        self._preset = preset
        if shading_changed or preset.generation == self.grains_generation:
            self.changing()
        # else only the generation changed: the view redraws when its tile arrives, never
        # before with the grains it has.

    def set_samples(self, samples: int) -> None:
        """Draw the view at rest with ``samples``×``samples`` samples a pixel (1 to 8)."""
        check_samples(samples)
        if samples != self.samples:
            self.samples = samples
            self.changing()

    def set_grains(self, textures: SandTextures) -> None:
        """A full tile from the editor's generation (it names its own), handed to the thread
        with the next job."""
        self._pending_grains = textures
        self.changing()

    def changing(self) -> None:
        """Something in view changes: draw at reduced resolution until it settles."""
        self._moving = True
        self._serial += 1
        self._refined_rows = 0
        self._sample_passes = self._sample_rows = 0
        self._settle.start()
        self._request_frame()

    def _settled(self) -> None:
        self._moving = False
        self._request_frame()

    def _fail(self, message: str) -> None:
        if self.error is None:
            self.error = message
            self.failed.emit(message)

    # -- jobs --------------------------------------------------------------------------------------

    def _size(self) -> tuple[int, int]:
        ratio = self.devicePixelRatioF()
        return (max(1, round(self.width() * ratio)), max(1, round(self.height() * ratio)))

    def _request_frame(self) -> None:
        self._wanted = True
        if self._in_flight is None and self.isVisible() and self.error is None:
            self._send_next()

    def _samples_left(self) -> bool:
        return self.samples > 1 and self._sample_passes < self.samples**2

    def _send_next(self) -> None:
        """Send the job the view needs now: a moving frame while anything changes (or before
        any), else the next band of the full-resolution frame, then of its samples; nothing once
        they are complete."""
        self._wanted = False
        size = self._size()
        if self._full.shape[:2] != size[::-1]:
            self._full = np.zeros((size[1], size[0], 4), np.uint8)
            self._full_image = _image_of(self._full)
            self._refined_rows = 0
            self._sample_passes = self._sample_rows = 0
        moving = self._moving or self._moving_image is None or self._pending_grains is not None
        refined = self._refined_rows >= size[1]
        if not moving and refined and not self._samples_left():
            return  # the full-resolution frame is complete
        grains, self._pending_grains = self._pending_grains, None
        common = dict(view=self._view, size=size, preset=self._preset, grains=grains,
                      serial=self._serial)  # fmt: skip
        if moving:
            job = RenderJob(scale=self.moving_scale, moving=self._moving, **common)
        else:
            first = self._sample_rows if refined else self._refined_rows
            if first == 0 and not refined:
                self._refine_ms, self._bands = 0.0, 0
            rows = int(FRAME_BUDGET_MS / max(self._pixel_ms * size[0], 1e-6))
            rows = min(max(rows, MIN_BAND_ROWS), size[1] - first)
            sample = (self._sample_passes, self.samples) if refined else None
            job = RenderJob(rows=(first, first + rows), exposure=self._band_exposure,
                            sample=sample, **common)  # fmt: skip
        self._in_flight = job
        self.gl.submit(job)

    def _frame_done(self, result: FrameResult) -> None:
        self._in_flight = None
        if result.error is not None:
            self._fail(result.error)
            return
        if result.pixels is None:  # no grains yet: their arrival asks again
            if self._wanted:
                self._request_frame()
            return
        self._take(result)
        refining = self._refined_rows < self._full.shape[0] or self._samples_left()
        if self._wanted or (not self._moving and refining):
            self._request_frame()

    def _take(self, result: FrameResult) -> None:
        job, timings, pixels = result.job, dict(result.timings), result.pixels
        self._pixel_ms = timings["total_ms"] / max(timings["pixels"], 1)
        if job.rows is None:
            self._moving_pixels = pixels
            self._moving_image = _image_of(pixels)
            self._band_exposure = timings["exposure"]  # metered band by band, each would differ
            self.moving_scale = adapted_scale(timings["total_ms"], job.scale)
            timings.update(scale=job.scale, refined=0.0)
        else:
            if job.serial != self._serial or job.size[::-1] != self._full.shape[:2]:
                return  # drawn for a view that has changed since
            first, end = result.rows or job.rows
            height = self._full.shape[0]
            self._full[height - end : height - first] = pixels
            if job.sample is None:
                self._refined_rows = end
                self._refine_ms += timings["total_ms"]
                self._bands += 1
            else:
                self._sample_rows = end % height
                self._sample_passes += end == height
                passes = self._sample_passes + self._sample_rows / height
                timings.update(sampled=passes / self.samples**2, samples=self.samples)
            timings.update(
                scale=1.0,
                rows=(first, end),
                refined=self._refined_rows / height,
                refine_ms=self._refine_ms,
                bands=self._bands,
            )
        self.frames += 1
        self.full_frames += timings["refined"] == 1.0 and job.sample is None
        self.last_timings = timings
        self.update()
        self.rendered.emit(timings)

    # -- Qt ----------------------------------------------------------------------------------------

    def paintEvent(self, event) -> None:
        painter = QPainter(self)
        try:
            if self._moving_image is None:
                painter.fillRect(self.rect(), QColor(0, 0, 0))
                return
            painter.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform)
            painter.drawImage(QRectF(self.rect()), self._moving_image)
            rows = self._refined_rows if not self._moving else 0
            if rows > 0 and self._full_image is not None:
                height, width = self._full.shape[:2]
                ratio = width / max(self.width(), 1)
                source = QRectF(0, height - rows, width, rows)
                target = QRectF(0, (height - rows) / ratio, width / ratio, rows / ratio)
                painter.drawImage(target, self._full_image, source)
        finally:
            painter.end()

    def showEvent(self, event) -> None:
        super().showEvent(event)
        if self._wanted:
            self._request_frame()

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        self.changing()

    def cleanup(self) -> None:
        """End the drawing thread and release its GL objects now (the view then stays as it
        was)."""
        self.gl.stop()
        if self.error is None:
            self.error = "The 3D view is closed."

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


def _image_of(pixels: np.ndarray) -> QImage:
    """A QImage over ``pixels`` (rows top-down, RGBA); the caller keeps ``pixels`` alive."""
    height, width = pixels.shape[:2]
    return QImage(pixels.data, width, height, width * 4, QImage.Format.Format_RGBX8888)


def _view_field(name: str) -> property:
    return property(lambda view: getattr(view._view, name), doc=f"The view's {name}.")


for _name in _VIEW_FIELDS:  # distance_m, pitch_deg, …: the view in hand
    setattr(SandView, _name, _view_field(_name))
