"""New grains off the frame loop: a thread with its own GL context, sharing textures with the
one that draws, brings a spare ``SandMaterial`` up to date while frames keep being submitted.

Two materials take turns: the front one is drawn; the back one is updated by the thread and then
swapped in. ``SandMaterial.update`` redoes only what a preset change needs, so a turn costs the
generation and nothing else once both exist.
"""

from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass

import moderngl

from sand_editor.generator.shared import read_shared
from sand_editor.gl import finish_without_gil
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial

# After each band of new grains, the GPU (on a CPU rasterizer: the cores) is left to the frame
# loop for this share of the band's time: frames keep coming, and grains take 1.5 times as long.
CEDE_SHARE = 0.5


def _cede_to_the_frame_loop() -> None:
    """Wait for the band just drawn, then leave the frame loop to draw alone for a while."""
    start = time.perf_counter()
    finish_without_gil()
    time.sleep(CEDE_SHARE * (time.perf_counter() - start))


@dataclass
class ReadyMaterial:
    """A material brought up to date for ``preset`` (request ``seq``), received at
    ``received_s`` (``time.perf_counter``)."""

    material: SandMaterial
    preset: Preset
    seq: int | None
    received_s: float
    error: str | None = None
    grains: str = "kept"  # "editor": its shared tile; "viewer": made here; "kept": none needed
    note: str | None = None  # why the editor's tile was not used (the grains were made here)


class GrainWorker:
    """Makes materials on ``window``'s context (a hidden GLFW window sharing objects with the
    drawing context; with no ``glfw``, a ``glwindow.SharedEGLContext``) in a daemon thread.

    It owns exactly two materials, made at start: the one on screen and the one being brought
    up to date; nothing is made or released per edit. ``request(preset, seq, shared)`` asks for
    a preset, with ``shared`` (segment name, size) naming the editor's finished tile of its
    grains, read instead of making them when it can be. A newer request replaces one not yet
    started, and stops one being made at its next band (``superseded`` counts both).
    ``poll()`` returns a finished ``ReadyMaterial`` or None; ``give_back(material)`` hands back
    the material that is no longer drawn, for the next turn.
    """

    MATERIALS = 2

    def __init__(self, glfw, window, texture_size: int) -> None:
        self._glfw = glfw
        self._window = window
        self._texture_size = texture_size
        self._wake = threading.Condition()
        self._request: tuple[Preset, int | None, float, tuple[str, int] | None] | None = None
        self._spare: list[SandMaterial] = []
        self._building = False
        self._closing = False
        self._ready: queue.SimpleQueue[ReadyMaterial] = queue.SimpleQueue()
        self._latest: SandMaterial | None = None  # the material last made ready: on screen
        self._started = threading.Event()
        self._start_error: BaseException | None = None
        self.superseded = 0
        self._thread = threading.Thread(target=self._run, name="vr-grains", daemon=True)
        self._thread.start()
        self._started.wait()
        if self._start_error is not None:
            raise self._start_error

    @property
    def busy(self) -> bool:
        """A request is waiting or being made."""
        return self._request is not None or self._building

    def request(
        self, preset: Preset, seq: int | None = None, shared: tuple[str, int] | None = None
    ) -> None:
        with self._wake:
            if self._request is not None:
                self.superseded += 1
            self._request = (preset, seq, time.perf_counter(), shared)
            self._wake.notify()

    def poll(self) -> ReadyMaterial | None:
        try:
            return self._ready.get_nowait()
        except queue.Empty:
            return None

    def wait(self, timeout_s: float) -> ReadyMaterial | None:
        """Block for the next finished material (start-up only: the frame loop polls)."""
        try:
            return self._ready.get(timeout=timeout_s)
        except queue.Empty:
            return None

    def give_back(self, material: SandMaterial) -> None:
        with self._wake:
            self._spare.append(material)
            self._wake.notify()

    def close(self) -> None:
        with self._wake:
            self._closing = True
            self._wake.notify()
        self._thread.join(timeout=30)

    # ---- the thread ---------------------------------------------------------------------------

    def _superseded(self) -> bool:
        """Asked between bands: a newer request is waiting, or the viewer is closing."""
        return self._request is not None or self._closing

    def _next_job(self) -> tuple[tuple, SandMaterial] | None:
        """The newest request and a spare material to make it in; None when closing."""
        with self._wake:
            while not self._closing and (self._request is None or not self._spare):
                self._wake.wait()
            if self._closing:
                return None
            job, self._request = self._request, None
            self._building = True
            return job, self._spare.pop()

    def _shared_grains(self, preset: Preset, shared) -> tuple[object, str | None]:
        """The editor's tile named by ``shared``, or None and why it cannot be used."""
        if shared is None:
            return None, None
        name, size = shared
        if size != self._texture_size:
            return None, f"its tile is {size}², the viewer's grains are {self._texture_size}²"
        try:
            return read_shared(name, size, preset.generation), None
        except ValueError as exc:
            return None, str(exc)

    def _run(self) -> None:
        try:
            if self._glfw is None:
                ctx = self._window.context()
            else:
                self._glfw.make_context_current(self._window)
                ctx = moderngl.create_context(require=330)
        except BaseException as exc:  # reported to the constructor
            self._start_error = exc
            self._started.set()
            return
        materials: list[SandMaterial] = []
        try:
            # Both materials are made now, before the first frame: making one compiles its
            # programs and computes its detail map, half a second that would stall frames.
            for _ in range(self.MATERIALS):
                materials.append(SandMaterial(ctx, self._texture_size))
            self._spare.extend(materials)
        except BaseException as exc:
            self._start_error = exc
            self._started.set()
            return
        self._started.set()
        try:
            while (next_job := self._next_job()) is not None:
                (preset, seq, received, shared), material = next_job
                grains, note = self._shared_grains(preset, shared)
                latest = self._latest
                if grains is None and material.grains_generation != preset.generation:
                    # A shading edit after new grains: the material on screen has them.
                    if latest is not None and latest.grains_generation == preset.generation:
                        grains = latest
                made_here = grains is None and material.grains_generation != preset.generation
                try:
                    finished = material.update(
                        preset,
                        grains,
                        between_bands=_cede_to_the_frame_loop,
                        cancelled=self._superseded,
                    )
                    # Everything written must be visible to the drawing context before use.
                    finish_without_gil()
                except Exception as exc:  # a preset the generator rejects keeps the old one
                    self.give_back(material)
                    self._ready.put(ReadyMaterial(None, preset, seq, received, str(exc)))
                    continue
                finally:
                    self._building = False
                if not finished:  # a newer request came in: it is made next, in this material
                    with self._wake:
                        self.superseded += 1
                    self.give_back(material)
                    continue
                shared_tile = grains is not None and grains is not latest
                source = "editor" if shared_tile else "viewer" if made_here else "kept"
                self._latest = material
                self._ready.put(ReadyMaterial(material, preset, seq, received, None, source, note))
        finally:
            # Programs and framebuffers of these materials belong to this context.
            for material in materials:
                material.release()
            ctx.release()
            if self._glfw is not None:
                self._glfw.make_context_current(None)
