"""File → Bake textures… and File → Export glTF…: the ``bake`` and ``export`` outputs written
from the window, on a worker thread, with a progress dialog whose Cancel leaves the files as they
were."""

from __future__ import annotations

import threading
from pathlib import Path

from PySide6.QtCore import QObject, Qt, Signal
from PySide6.QtWidgets import QProgressDialog, QWidget

from sand_editor.preset import Preset

_PROGRESS_STEPS = 1000


class BakeJob(QObject):
    """Runs ``sand_editor.bake.BakeSteps`` (or, with ``export``, the glTF export's steps into
    ``out_dir`` as a file, its images ``tiles`` varied tiles across) on a worker thread with its
    own headless context.

    Signals (delivered in the GUI thread)
    -------------------------------------
    progressed(float, str)
        Fraction done and the step under way.
    succeeded(dict)
        The material record of the finished bake.
    failed(str)
        Why the bake stopped; nothing was written.
    cancelled()
        ``cancel()`` took effect; nothing was written.
    """

    progressed = Signal(float, str)
    succeeded = Signal(object)
    failed = Signal(str)
    cancelled = Signal()

    def __init__(
        self,
        preset: Preset,
        size: int,
        out_dir: Path,
        parent: QObject | None = None,
        export: bool = False,
        tiles: int = 1,
    ):
        super().__init__(parent)
        self.preset, self.size, self.out_dir = preset, size, Path(out_dir)
        self.export, self.tiles = export, tiles
        self.verb = "Exporting" if export else "Baking"
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sand-bake", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def cancel(self) -> None:
        self._cancel.set()

    def wait(self, timeout: float | None = None) -> bool:
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def _run(self) -> None:
        import moderngl

        from sand_editor.bake import BakeSteps
        from sand_editor.export.gltf import PatchOptions
        from sand_editor.export.run import ExportSteps
        from sand_editor.gl import REQUIRED_GL_VERSION

        ctx = None
        try:
            ctx = moderngl.create_standalone_context(require=REQUIRED_GL_VERSION, backend="egl")
            if self.export:
                options = PatchOptions(tiles=self.tiles)
                steps = ExportSteps(self.preset, self.out_dir, size=self.size, options=options,
                                    ctx=ctx)  # fmt: skip
            else:
                steps = BakeSteps(self.preset, self.size, self.out_dir, ctx=ctx)
            try:
                for fraction, step in steps:
                    # The last step writes every file at once; before it, stopping leaves
                    # the folder as it was.
                    if self._cancel.is_set() and fraction < 1.0:
                        self.cancelled.emit()
                        return
                    self.progressed.emit(fraction, step)
            finally:
                steps.close()
            self.succeeded.emit(steps.record)
        except Exception as error:  # disk, permission and driver errors are shown
            into = "export to" if self.export else "bake into"
            self.failed.emit(f"Cannot {into} {self.out_dir}: {error}")
        finally:
            if ctx is not None:
                ctx.release()


class BakeDialog(QProgressDialog):
    """Progress of one ``BakeJob``; Cancel stops it. ``result`` is the record, or None."""

    def __init__(self, job: BakeJob, parent: QWidget | None = None):
        super().__init__(
            f"{job.verb} {job.preset.name} at {job.size}²…", "Cancel", 0, _PROGRESS_STEPS, parent
        )
        self.setWindowTitle("Export glTF" if job.export else "Bake textures")
        self.setWindowModality(Qt.WindowModality.WindowModal)
        self.setMinimumDuration(0)
        self.setAutoClose(False)
        self.setAutoReset(False)
        self.job = job
        self.result: dict | None = None
        self.error: str | None = None
        job.progressed.connect(self._progressed)
        job.succeeded.connect(self._succeeded)
        job.failed.connect(self._failed)
        job.cancelled.connect(self._finished)
        self.canceled.connect(job.cancel)

    def cancel(self) -> None:
        """Stop the bake (as the Cancel button does); nothing is written."""
        self.job.cancel()
        super().cancel()

    def _progressed(self, fraction: float, step: str) -> None:
        self.setLabelText(f"{self.job.verb} {self.job.preset.name} at {self.job.size}²: {step}…")
        self.setValue(round(fraction * _PROGRESS_STEPS))

    def _succeeded(self, record: dict) -> None:
        self.result = record
        self._finished()

    def _failed(self, message: str) -> None:
        self.error = message
        self._finished()

    def _finished(self) -> None:
        self.job.wait()
        self.done(0)
