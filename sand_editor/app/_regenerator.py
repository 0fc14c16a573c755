"""Generation of the grain textures on a worker thread, shared by every view of the editor.

One generation per edit: the 2D preview and the 3D view both take the tiles this produces. The
worker draws in its own headless EGL context (one per thread), so the GUI thread, which owns the
3D view's GLX context, never has to switch contexts, and never waits for a generation: the worker
waits for its draws without holding the interpreter, and holds it only to queue a band of rows
or to copy a read-back.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Iterator

from PySide6.QtCore import QObject, QTimer, Signal

from sand_editor.generator import SandTextures, generate, gl_generator
from sand_editor.generator.noise import NoiseConstants
from sand_editor.gl import finish_without_gil
from sand_editor.preset import Preset

DEBOUNCE_MS = 20
FIRST_SIZE = 128
BAND_ROWS = 128
CACHE_TILES = 3


class TextureCache:
    """The last few full tiles, by (generation parameters, size): undo, redo and size changes
    back to a recent value show their tile again without generating it."""

    def __init__(self, capacity: int = CACHE_TILES) -> None:
        self.capacity = capacity
        self._tiles: OrderedDict[tuple, tuple[SandTextures, dict]] = OrderedDict()

    def get(self, key: tuple) -> tuple[SandTextures, dict] | None:
        entry = self._tiles.get(key)
        if entry is not None:
            self._tiles.move_to_end(key)
        return entry

    def put(self, key: tuple, textures: SandTextures, statistics: dict) -> None:
        self._tiles[key] = (textures, statistics)
        self._tiles.move_to_end(key)
        while len(self._tiles) > self.capacity:
            self._tiles.popitem(last=False)

    def __len__(self) -> int:
        return len(self._tiles)


class _Job:
    def __init__(self, serial: int, generation, size: int) -> None:
        self.serial = serial
        self.generation = generation
        self.size = size


class Regenerator(QObject):
    """Generates a preset's textures progressively on a worker thread.

    A request waits ``DEBOUNCE_MS`` for further requests (a slider drag sends many), then the
    worker renders a quick ``FIRST_SIZE`` tile and the full one in bands of ``BAND_ROWS`` rows;
    a newer request cancels the running generation at its next band. The full tile is shown
    (``produced``) before its statistics are counted (``finished``).

    Signals
    -------
    produced(SandTextures, bool)
        A tile is ready: first the quick low-resolution one (False), then the full one (True).
    finished(SandTextures, float)
        The full tile and the seconds from the request's start (0 for a cached tile).
    failed(str)
        Generation raised; the message says why.
    """

    produced = Signal(object, bool)
    finished = Signal(object, float)
    failed = Signal(str)
    # From the worker thread; queued into the GUI thread.
    _delivered = Signal(int, object, bool)
    _counted = Signal(int, object)
    _errored = Signal(int, str)

    def __init__(self, size: int = 512, parent: QObject | None = None):
        super().__init__(parent)
        self.size = size
        self.generations = 0
        self.cache = TextureCache()
        # Statistics of the last full tile (coverage, gaps, grains), computed by the worker.
        self.statistics: dict | None = None
        # Generation parameters of the tile last produced (low or full resolution), and of the
        # last request whose generation failed.
        self.generation = None
        self.failed_generation = None
        self._preset: Preset | None = None
        self._serial = 0  # the job the GUI wants; older ones are dropped
        self._running_serial: int | None = None
        self._started_at = 0.0
        self._final: SandTextures | None = None
        self._job: _Job | None = None
        self._condition = threading.Condition()
        self._stopping = False
        self._thread: threading.Thread | None = None
        self._debounce = QTimer(self, singleShot=True, interval=DEBOUNCE_MS)
        self._debounce.timeout.connect(self._start)
        self._delivered.connect(self._on_delivered)
        self._counted.connect(self._on_counted)
        self._errored.connect(self._on_error)

    @property
    def busy(self) -> bool:
        """A generation is waiting for its debounce or running."""
        return self._debounce.isActive() or self._running_serial == self._serial

    @property
    def running(self) -> bool:
        return self._running_serial == self._serial

    def request(self, preset: Preset) -> None:
        self._preset = preset
        self._serial += 1  # cancels whatever the worker is doing
        self._running_serial = None
        cached = self.cache.get((preset.generation, self.size))
        if cached is not None:
            self._debounce.stop()
            textures, statistics = cached
            self.statistics = statistics
            self.generation = preset.generation
            self.produced.emit(textures, True)
            self.finished.emit(textures, 0.0)
            return
        self._debounce.start()

    def full_tile(self, generation, size: int) -> SandTextures | None:
        """The full tile of ``generation`` at ``size`` if there is one: the one just delivered
        (before its statistics are counted), or one from the cache."""
        final = self._final
        if final is not None and final.generation == generation and final.size == size:
            return final
        cached = self.cache.get((generation, size))
        return None if cached is None else cached[0]

    def set_size(self, size: int) -> None:
        if size != self.size:
            self.size = size
            if self._preset is not None:
                self.request(self._preset)

    def shutdown(self) -> None:
        """Stop the worker (its generation is dropped) and wait for it."""
        self._debounce.stop()
        self._serial += 1
        with self._condition:
            self._stopping = True
            self._condition.notify()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    # -- GUI thread ------------------------------------------------------------------------------

    def _start(self) -> None:
        self.generations += 1
        self._started_at = time.perf_counter()
        self._running_serial = self._serial
        job = _Job(self._serial, self._preset.generation, self.size)
        with self._condition:
            self._job = job
            self._stopping = False
            self._condition.notify()
        if self._thread is None:
            self._thread = threading.Thread(target=self._work, name="sand-generator", daemon=True)
            self._thread.start()

    def _on_delivered(self, serial: int, textures: SandTextures, final: bool) -> None:
        if serial != self._serial:
            return  # a newer request replaced this one while it was on its way
        self.generation = self._preset.generation
        self.produced.emit(textures, final)
        if final:
            self._final = textures

    def _on_counted(self, serial: int, statistics: dict) -> None:
        if serial != self._serial:
            return
        self._running_serial = None
        self.statistics = statistics
        textures = self._final
        self.cache.put((self._preset.generation, textures.size), textures, statistics)
        self.finished.emit(textures, time.perf_counter() - self._started_at)

    def _on_error(self, serial: int, message: str) -> None:
        if serial == self._serial:
            self._running_serial = None
            self.failed_generation = self._preset.generation
            self.failed.emit(message)

    # -- worker thread ---------------------------------------------------------------------------

    def _work(self) -> None:
        import moderngl

        from sand_editor.gl import REQUIRED_GL_VERSION

        ctx = None
        try:
            while True:
                with self._condition:
                    while self._job is None and not self._stopping:
                        self._condition.wait()
                    if self._stopping:
                        return
                    job, self._job = self._job, None
                if ctx is None:
                    try:
                        # This thread's own headless context, released when the thread ends.
                        ctx = moderngl.create_standalone_context(
                            require=REQUIRED_GL_VERSION, backend="egl"
                        )
                    except Exception as error:
                        self._errored.emit(job.serial, f"Cannot create a GL context: {error}")
                        continue
                self._generate(job, ctx)
        finally:
            if ctx is not None:
                ctx.release()

    def _generate(self, job: _Job, ctx) -> None:
        tiles = self._tiles(job, ctx)
        try:
            for textures in tiles:
                if job.serial != self._serial or self._stopping:
                    return
                final = textures.size == job.size
                self._delivered.emit(job.serial, textures, final)
                if final:
                    # Counted after the tile is on its way: the preview need not wait for it.
                    self._counted.emit(job.serial, textures.statistics(job.generation.layers))
        except Exception as error:  # GL and driver errors are shown, not fatal
            self._errored.emit(job.serial, f"Cannot generate the textures: {error}")
        finally:
            tiles.close()  # releases the GPU target of a generation cut short, now

    def _tiles(self, job: _Job, ctx) -> Iterator[SandTextures]:
        """The quick tile, then the full one drawn in bands. The worker waits for each band
        without holding the interpreter, so the GUI thread runs Python while the band is drawn;
        a newer request is noticed at the next band."""
        generator = gl_generator(ctx)
        constants = NoiseConstants.from_generation(job.generation)
        if FIRST_SIZE < job.size:
            yield generate(job.generation, FIRST_SIZE, ctx=ctx)
        target = generator.allocate(job.size)
        try:
            for _rows in generator.render_in_bands(constants, target, BAND_ROWS):
                finish_without_gil()
                if job.serial != self._serial or self._stopping:
                    return
            yield target.read(constants, job.generation)
        finally:
            target.release()
