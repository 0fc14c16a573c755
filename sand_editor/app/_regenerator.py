"""Live regeneration of the preview textures without blocking the event loop."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

from PySide6.QtCore import QObject, QTimer, Signal
from PySide6.QtGui import QOpenGLContext

from sand_editor.generator import SandTextures, generate_progressive
from sand_editor.gl import standalone_current
from sand_editor.preset import Preset

DEBOUNCE_MS = 60
FIRST_SIZE = 128


@contextmanager
def headless_gl() -> Iterator[None]:
    """The headless context current for the block, with Qt's (the 3D view's, or the window's
    compositor) released first: the two cannot be current together on this thread."""
    current = QOpenGLContext.currentContext()
    if current is not None:
        current.doneCurrent()
    with standalone_current():
        yield


class Regenerator(QObject):
    """Generates a preset's textures progressively, one short GPU step per event-loop turn.

    A request waits ``DEBOUNCE_MS`` for further requests (a slider drag sends many), then
    starts ``generate_progressive``; a newer request cancels the running generation.

    Signals
    -------
    produced(SandTextures, bool)
        A tile is ready: first the quick low-resolution one (False), then the full one (True).
    finished(SandTextures, float)
        The full tile and the seconds the generation took.
    failed(str)
        Generation raised; the message says why.
    """

    produced = Signal(object, bool)
    finished = Signal(object, float)
    failed = Signal(str)

    def __init__(self, size: int = 512, parent: QObject | None = None):
        super().__init__(parent)
        self.size = size
        self.generations = 0
        self._preset: Preset | None = None
        self._steps: Iterator[SandTextures | None] | None = None
        self._started_at = 0.0
        self._debounce = QTimer(self, singleShot=True, interval=DEBOUNCE_MS)
        self._debounce.timeout.connect(self._start)
        # A 0 ms timer runs one step each time the event loop has drained its queue.
        self._step_timer = QTimer(self, interval=0)
        self._step_timer.timeout.connect(self._step)

    @property
    def busy(self) -> bool:
        """A generation is waiting for its debounce or running."""
        return self._debounce.isActive() or self._steps is not None

    @property
    def running(self) -> bool:
        return self._steps is not None

    def request(self, preset: Preset) -> None:
        self._preset = preset
        self._cancel()
        self._debounce.start()

    def set_size(self, size: int) -> None:
        if size != self.size:
            self.size = size
            if self._preset is not None:
                self.request(self._preset)

    def _cancel(self) -> None:
        self._step_timer.stop()
        if self._steps is not None:
            # close() runs the generator's cleanup now, releasing its GPU target.
            with headless_gl():
                self._steps.close()
            self._steps = None

    def _start(self) -> None:
        self.generations += 1
        self._started_at = time.perf_counter()
        self._steps = generate_progressive(self._preset, self.size, first_size=FIRST_SIZE)
        self._step_timer.start()

    def _step(self) -> None:
        try:
            with headless_gl():
                textures = next(self._steps)
        except StopIteration:
            self._cancel()
            return
        except Exception as error:  # GL and driver errors are shown, not fatal
            self._cancel()
            self.failed.emit(f"Cannot generate the textures: {error}")
            return
        if textures is None:
            return
        final = textures.size == self.size
        self.produced.emit(textures, final)
        if final:
            self._cancel()
            self.finished.emit(textures, time.perf_counter() - self._started_at)
