"""The 3D view's drawing thread: a headless GL context of its own with the renderer and the
material, so the event loop never waits on a frame.

On a CPU rasterizer the waiting is the drawing: a frame drawn on the GUI thread kept every click,
key and timer waiting for it. Here the GUI thread sends jobs (``RenderJob``: the view, the size,
the sand) one at a time and gets back pixels (``FrameResult``) through a Qt signal; the renderer
waits for its passes without Python's lock (``SandRenderer.wait_without_gil``), so the GUI
thread runs meanwhile.
"""

from __future__ import annotations

import dataclasses
import queue
import threading
import time
from collections.abc import Callable

import moderngl
import numpy as np
from PySide6.QtCore import QObject, Signal

from sand_editor.app._refinement import band_camera
from sand_editor.generator import SandTextures
from sand_editor.gl import finish_without_gil, headless_context
from sand_editor.preset import Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.render.still import GatheredLight, sample_camera


@dataclasses.dataclass(frozen=True)
class ViewParams:
    """What the camera sees: the view's controls at the moment a job was sent."""

    distance_m: float = 1.0
    pitch_deg: float = 45.0
    heading_deg: float = 0.0
    time_hours: float = 10.0
    mode: str = "full"
    show_sphere: bool = False
    exposure: float | None = None  # None: metered and adapted, as an eye does


@dataclasses.dataclass(frozen=True)
class RenderJob:
    """One frame to draw: at ``scale`` of ``size`` (a moving frame), or the rows
    ``[rows[0], rows[1])`` (from the bottom) of the full-resolution frame."""

    view: ViewParams
    size: tuple[int, int]
    preset: Preset
    grains: SandTextures | None = None  # a new tile to upload first
    scale: float = 1.0
    rows: tuple[int, int] | None = None
    exposure: float | None = None  # overrides the view's (the bands use their moving frame's)
    moving: bool = False
    serial: int = 0  # the view's change count when the job was sent
    # For a band of a still with more samples a pixel: (which sample, samples a side); the
    # band then shows the light its samples so far gathered. A band of either kind that ends
    # the frame brings the whole frame, its light bloomed at once.
    sample: tuple[int, int] | None = None


@dataclasses.dataclass
class FrameResult:
    """What a job drew: ``pixels`` (rows top-down, RGBA) and the renderer's timings, or the
    ``error`` that stopped it; no pixels while the view has no grains yet."""

    job: RenderJob | None  # None: the thread could not start
    pixels: np.ndarray | None = None
    timings: dict = dataclasses.field(default_factory=dict)
    error: str | None = None
    # The full-resolution frame's rows (from the bottom) the pixels cover: the job's band, or
    # the whole frame once its last band is in (bloomed as a whole).
    rows: tuple[int, int] | None = None


class _Reporter(QObject):
    """Carries results from the drawing thread to the GUI thread (a queued connection)."""

    done = Signal(object)


@dataclasses.dataclass
class _Call:
    """A function to run on the drawing thread with its context current (tests, benchmarks)."""

    function: Callable
    finished: threading.Event = dataclasses.field(default_factory=threading.Event)
    value: object = None
    error: BaseException | None = None


class RenderWorker:
    """Owns the drawing thread and everything GL it uses; ``stop`` releases it all there.

    ``ctx``, ``renderer`` and ``material`` belong to the thread: other threads read their plain
    attributes at most, and reach GL only through ``call``. ``release_error`` is the context's
    GL error state when it was released (None until then).
    """

    def __init__(self, on_result: Callable[[FrameResult], None]) -> None:
        self.ctx: moderngl.Context | None = None
        self.renderer: SandRenderer | None = None
        self.material: SandMaterial | None = None
        self.release_error: str | None = None
        self.grain_uploads = 0
        self.start_error: str | None = None
        self._targets: dict[str, moderngl.Framebuffer] = {}
        self._gathered: tuple[tuple, GatheredLight] | None = None  # (the view's key, its light)
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()
        self._reporter = _Reporter()
        self._reporter.done.connect(on_result)
        self._thread = threading.Thread(target=self._run, name="sand-view", daemon=True)
        self._thread.start()

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def submit(self, job: RenderJob) -> None:
        self._jobs.put(job)

    def call(self, function: Callable[[moderngl.Context], object], timeout: float = 60.0):
        """``function(ctx)`` run on the drawing thread after the jobs sent before; its value."""
        if not self.running:
            raise RuntimeError("the 3D view's drawing thread has stopped")
        call = _Call(function)
        self._jobs.put(call)
        if not call.finished.wait(timeout):
            raise TimeoutError("the 3D view's drawing thread did not answer")
        if call.error is not None:
            raise call.error
        return call.value

    def stop(self, timeout: float = 30.0) -> None:
        """Finish the job in hand, release every GL object and the context, end the thread."""
        if self._thread.is_alive():
            self._jobs.put(None)
            self._thread.join(timeout)

    # -- the drawing thread ----------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self.ctx = headless_context()
            self.renderer = SandRenderer(self.ctx)
            self.renderer.exposure.adapt_over_time = True
            self.renderer.wait_without_gil = True
        except Exception as error:
            self.start_error = f"Cannot start the 3D view: {error}"
            self._release()
            self._reporter.done.emit(FrameResult(None, error=self.start_error))
            self._drain()
            return
        while (job := self._jobs.get()) is not None:
            if isinstance(job, _Call):
                try:
                    job.value = job.function(self.ctx)
                except BaseException as error:  # handed to the caller's thread
                    job.error = error
                job.finished.set()
                continue
            try:
                result = self._draw(job)
            except Exception as error:  # a driver error is shown, not fatal to the editor
                result = FrameResult(job, error=f"3D view: {error}")
            self._reporter.done.emit(result)
        self._release()

    def _drain(self) -> None:
        # Calls still get an answer (their error) after a failed start.
        while (job := self._jobs.get()) is not None:
            if isinstance(job, _Call):
                job.error = RuntimeError(self.start_error)
                job.finished.set()

    def _sync_material(self, job: RenderJob) -> None:
        """Upload a new tile, or follow a shading change, in the material."""
        if job.grains is not None:
            textures = job.grains
            if self.material is None or self.material.texture_size != textures.size:
                # Swapped, then released: other threads never see the view without one.
                old, self.material = self.material, SandMaterial(self.ctx, textures.size)
                self.renderer.set_material(self.material)
                if old is not None:
                    old.release()
            self.material.update(job.preset, grains=textures)
            self.grain_uploads += 1
        elif (
            self.material is not None
            and self.material.preset != job.preset
            # The view never makes grains: a generation edit shows with its tile.
            and job.preset.generation == self.material.grains_generation
        ):
            self.material.update(job.preset)

    def view_camera(self, view: ViewParams, size: tuple[int, int]):
        """The camera of ``view`` for a frame of ``size`` over the renderer's terrain."""
        terrain = self.renderer.terrain
        return camera_at_distance(
            view.distance_m,
            view.pitch_deg,
            size[0] / size[1],
            ground_height=lambda x, z: float(terrain.height(x, z)),
            heading_deg=view.heading_deg,
        )

    def _draw(self, job: RenderJob) -> FrameResult:
        start = time.perf_counter()
        self._sync_material(job)
        if self.material is None:
            return FrameResult(job)  # the first tile is still being generated
        view = job.view
        width, height = job.size
        camera = self.view_camera(view, job.size)
        footprint = 1.0
        if job.sample is not None:
            index, samples = job.sample
            camera = sample_camera(camera, samples, index, (width, height))
            footprint = 1.0 / samples
        if job.rows is None:
            size = (max(1, round(width * job.scale)), max(1, round(height * job.scale)))
            target = self._target("moving", *size)
            viewport = (0, 0, *size)
        else:
            first, end = job.rows
            target = self._target("full", width, height)
            camera = band_camera(camera, first, end, height)
            viewport = (0, first, width, end - first)
        request = FrameRequest(
            camera,
            sky_at(view.time_hours),
            view.mode,
            viewport=viewport,
            exposure=job.exposure if job.exposure is not None else view.exposure,
            show_sphere=view.show_sphere,
            moving=job.moving,
            footprint_scale=footprint,
        )
        drawn_pixels = viewport[2] * viewport[3]
        if job.rows is None:
            timings = self.renderer.render(target, request)
        else:
            timings, viewport = self._gather(job, request, target, viewport)
        finish_without_gil()
        data = target.read(viewport=viewport, components=4)
        pixels = np.frombuffer(data, np.uint8).reshape(viewport[3], viewport[2], 4)[::-1]
        timings["total_ms"] = (time.perf_counter() - start) * 1e3
        timings["pixels"] = drawn_pixels
        rows = None if job.rows is None else (viewport[1], viewport[1] + viewport[3])
        return FrameResult(job, np.ascontiguousarray(pixels), timings, rows=rows)

    def _gather(self, job: RenderJob, request: FrameRequest, target, viewport):
        """A band of the full-resolution frame, or of one sample of a still: its light added
        to what the view's samples have gathered there (the first sample starts it anew), the
        band showing their average, and the last band of a pass resolving the whole frame, so
        that bloom spreads across the bands as over a frame drawn at once (a band's own bloom
        is cut at its edges, which smears a sparkle's glow sideways). Returns the timings and
        the viewport to read."""
        first, end = job.rows
        index, samples = job.sample or (0, 1)
        key = (job.serial, job.size, samples)
        if self._gathered is None or self._gathered[0] != key:
            self._gathered = (key, GatheredLight(*job.size))
        gathered = self._gathered[1]
        if index == 0:
            gathered.forget(first, end)
        start = time.perf_counter()
        gathered.add(self.renderer.draw_light(request, viewport[2:]), first)
        drawn = (time.perf_counter() - start) * 1e3
        if end == job.size[1]:
            viewport = (0, 0, *job.size)
            scene = gathered.scene()
        elif samples == 1:
            scene = None  # the band's own light, still in the scene target
        else:
            scene = gathered.scene(first, end)
        timings = self.renderer.resolve_light(target, viewport, request, scene)
        timings["surface_ms"] = drawn
        return timings, viewport

    def _target(self, name: str, width: int, height: int) -> moderngl.Framebuffer:
        """An offscreen colour target, kept until its size changes."""
        current = self._targets.get(name)
        if current is None or current.size != (width, height):
            self._release_target(name)
            texture = self.ctx.texture((width, height), 4)
            self._targets[name] = self.ctx.framebuffer([texture])
        return self._targets[name]

    def _release_target(self, name: str) -> None:
        framebuffer = self._targets.pop(name, None)
        if framebuffer is not None:
            for texture in framebuffer.color_attachments:
                texture.release()
            framebuffer.release()

    def _release(self) -> None:
        if self.ctx is None:
            return
        try:
            for owner in (self.renderer, self.material):
                if owner is not None:
                    owner.release()
            for name in list(self._targets):
                self._release_target(name)
            self.release_error = self.ctx.error
            self.ctx.release()
        finally:
            self.ctx = self.material = self.renderer = None
            self._gathered = None
