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


class GrainWorker:
    """Makes materials on ``window``'s context (a hidden GLFW window sharing objects with the
    drawing context) in a daemon thread.

    ``request(preset, seq)`` queues a preset (a newer request replaces a waiting one);
    ``poll()`` returns a finished ``ReadyMaterial`` or None; ``give_back(material)`` hands the
    material that is no longer drawn back for the next turn.
    """

    def __init__(self, glfw, window, texture_size: int) -> None:
        self._glfw = glfw
        self._window = window
        self._texture_size = texture_size
        self._requests: queue.Queue = queue.Queue()
        self._ready: queue.SimpleQueue[ReadyMaterial] = queue.SimpleQueue()
        self._spare: list[SandMaterial] = []
        self._lock = threading.Lock()
        self._started = threading.Event()
        self._start_error: BaseException | None = None
        self.busy = False
        self._thread = threading.Thread(target=self._run, name="vr-grains", daemon=True)
        self._thread.start()
        self._started.wait()
        if self._start_error is not None:
            raise self._start_error

    def request(self, preset: Preset, seq: int | None = None) -> None:
        with self._lock:
            # Only the newest edit matters: drop ones not yet started.
            while True:
                try:
                    self._requests.get_nowait()
                except queue.Empty:
                    break
            self.busy = True
            self._requests.put((preset, seq, time.perf_counter()))

    def poll(self) -> ReadyMaterial | None:
        try:
            ready = self._ready.get_nowait()
        except queue.Empty:
            return None
        with self._lock:
            self.busy = not self._requests.empty()
        return ready

    def wait(self, timeout_s: float) -> ReadyMaterial | None:
        """Block for the next finished material (start-up only: the frame loop polls)."""
        try:
            ready = self._ready.get(timeout=timeout_s)
        except queue.Empty:
            return None
        with self._lock:
            self.busy = not self._requests.empty()
        return ready

    def give_back(self, material: SandMaterial) -> None:
        self._requests.put(("spare", material))

    def close(self) -> None:
        self._requests.put(None)
        self._thread.join(timeout=30)

    # ---- the thread ---------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self._glfw.make_context_current(self._window)
            ctx = moderngl.create_context(require=330)
        except BaseException as exc:  # reported to the constructor
            self._start_error = exc
            self._started.set()
            return
        materials: list[SandMaterial] = []
        try:
            # Both materials are made now, before the first frame: making one compiles its
            # programs and computes its ripple maps, half a second that would stall frames.
            for _ in range(2):
                materials.append(SandMaterial(ctx, self._texture_size))
            self._spare.extend(materials)
        except BaseException as exc:
            self._start_error = exc
            self._started.set()
            return
        self._started.set()
        try:
            while True:
                job = self._requests.get()
                if job is None:
                    break
                if job[0] == "spare":
                    self._spare.append(job[1])
                    continue
                preset, seq, received = job
                if self._spare:
                    material = self._spare.pop()
                else:  # both taken: the one on screen comes back with the next swap
                    material = SandMaterial(ctx, self._texture_size)
                    materials.append(material)
                try:
                    material.update(preset, between_bands=_cede_to_the_frame_loop)
                    # Everything written must be visible to the drawing context before use.
                    finish_without_gil()
                except Exception as exc:  # a preset the generator rejects keeps the old one
                    self._spare.append(material)
                    self._ready.put(ReadyMaterial(None, preset, seq, received, str(exc)))
                    continue
                self._ready.put(ReadyMaterial(material, preset, seq, received))
        finally:
            # Programs and framebuffers of these materials belong to this context.
            for material in materials:
                material.release()
            ctx.release()
            self._glfw.make_context_current(None)
