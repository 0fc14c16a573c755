"""The editor's side of the VR link: start ``sand-editor vr --control stdio`` as a child process,
stream the preset being edited, the time of day and the mode to it, and turn its answers into Qt
signals (protocol: ``sand_editor.vr.link``). The window's button and bindings are in
``_vr_controls``, its command line in ``_vr_command``, the coalescing of what is sent in
``_vr_outbox``, the tiles handed over in ``_vr_grains``, and the wording of how the viewer ended
in ``_vr_exit``.

The viewer is a separate process so that a runtime, driver or headset problem can never take the
editor down: whatever the viewer does (crash, hang, refuse to start), the editor says what
happened and stays usable. Nothing here waits on the process on the GUI thread.
"""

from __future__ import annotations

import collections
import os
import shutil
import sys
import tempfile
from functools import partial
from pathlib import Path

from PySide6.QtCore import QObject, QProcess, QProcessEnvironment, QTimer, Signal

from sand_editor.app._vr_command import PYTHON_VARIABLE, WRAPPER_VARIABLE, viewer_command
from sand_editor.app._vr_exit import SIGKILL, describe_exit
from sand_editor.app._vr_outbox import Outbox
from sand_editor.preset import Preset
from sand_editor.vr.link import check_time_fields, decode, encode

READY_TIMEOUT_MS = 60_000  # first frame: shader compile and grain generation on llvmpipe
ANSWER_TIMEOUT_MS = 30_000  # a preset not on screen by then: the viewer is not responding
QUIT_GRACE_MS = 3000  # after "quit", before SIGTERM
TERMINATE_GRACE_MS = 2000  # after SIGTERM, before SIGKILL
STDERR_LINES_KEPT = 40
STDERR_LINES_SHOWN = 6


class VrLink(QObject):
    """One viewer process at a time and the JSON-lines conversation with it.

    Signals
    -------
    started()
        The process is running (not yet showing anything).
    ready(dict)
        The viewer submitted its first frame: ``backend``, ``runtime``, ``system``, ``views``.
    state(str)
        The session state changed (``FOCUSED``, ``VISIBLE``, ``STOPPING``…).
    applied(int, float)
        The preset with that sequence number is on screen; the viewer's ms from receipt.
    time(dict)
        The time of day changed in VR: any of ``hours``, ``day_speed``, ``playing``.
    mode(str)
        The render mode was changed in VR.
    error(str)
        A recoverable problem the viewer reported, or a line it sent that is not the protocol.
    finished(int, str)
        The process is gone: its exit status (negative: the signal that killed it; -1 when it
        never started) and a sentence saying what happened.
    """

    started = Signal()
    ready = Signal(object)
    state = Signal(str)
    applied = Signal(int, float)
    time = Signal(object)
    mode = Signal(str)
    error = Signal(str)
    finished = Signal(int, str)

    def __init__(self, parent: QObject | None = None, tiles=None):
        super().__init__(parent)
        self.tiles = tiles  # a SharedTiles: the editor's tiles go to the viewer with its presets
        self.share_tiles = True  # False: the viewer makes its grains itself (for comparison)
        self.ready_timeout_ms = READY_TIMEOUT_MS
        self.extra_args: tuple[str, ...] = ()  # more viewer options, e.g. ("--render-scale", "0.5")
        self.process: QProcess | None = None
        self.desktop = False
        self.ready_info: dict | None = None
        self.session_state = ""
        self.stderr_lines: collections.deque[str] = collections.deque(maxlen=STDERR_LINES_KEPT)
        self.sent: collections.Counter[str] = collections.Counter()  # messages by type
        self._outbox = Outbox(self._send, lambda: self.is_ready, self._accepting, self)
        self._outbox.tiles = tiles
        self.applied_grains = ""  # where the grains of the preset last shown came from
        self._outbox.preset_sent.connect(self._preset_sent)
        self._stdout = b""
        self._folder: str | None = None
        # Why the editor ended the viewer itself (it hung); None when it exited on its own.
        self.stop_reason: str | None = None
        self._ready_timer = QTimer(self, singleShot=True)
        self._ready_timer.timeout.connect(self._ready_timed_out)
        self.answer_timeout_ms = ANSWER_TIMEOUT_MS
        self.responding = True  # False while a sent preset has waited too long for "applied"
        self._answer_timer = QTimer(self, singleShot=True)
        self._answer_timer.timeout.connect(self._answer_timed_out)
        self._terminate_timer = QTimer(self, singleShot=True, interval=QUIT_GRACE_MS)
        self._terminate_timer.timeout.connect(self._terminate)
        self._kill_timer = QTimer(self, singleShot=True, interval=TERMINATE_GRACE_MS)
        self._kill_timer.timeout.connect(self._kill)

    # -- life cycle ---------------------------------------------------------------------------

    @property
    def running(self) -> bool:
        """True from ``start`` until ``finished`` has been emitted."""
        return self.process is not None

    @property
    def is_ready(self) -> bool:
        return self.ready_info is not None

    @property
    def seq(self) -> int:
        """The number of the latest preset sent."""
        return self._outbox.seq

    @property
    def latency_ms(self) -> dict[int, float]:
        """Sequence number → ms from the edit to the viewer showing it, for the latest presets."""
        return self._outbox.latency_ms

    @property
    def unanswered(self) -> int:
        """Presets sent and neither shown nor superseded yet."""
        return self._outbox.unanswered

    @property
    def last_sent_preset(self) -> Preset | None:
        """The preset the viewer was last given (on its command line or over the link)."""
        return self._outbox.last_sent_preset

    @property
    def stopping(self) -> bool:
        return self._terminate_timer.isActive() or self._kill_timer.isActive()

    def start(self, preset: Preset, desktop: bool = False, scene: dict | None = None) -> None:
        """Start the viewer on ``preset`` and ``scene`` (see ``viewer_command``); ``finished``
        follows if it cannot start."""
        if self.running:
            raise RuntimeError("the VR viewer is already running")
        self.desktop = desktop
        self.ready_info = None
        self.session_state = ""
        self.stderr_lines.clear()
        self._stdout = b""
        self.stop_reason = None
        self._outbox.clear()
        # A wrapper may run the viewer where this machine's temporary folder is not (a chroot,
        # a container): the preset then goes over the link, as its first message.
        through_link = bool(os.environ.get(WRAPPER_VARIABLE, "").strip())
        preset_file = None
        try:
            if not through_link:
                self._folder = tempfile.mkdtemp(prefix="sand-editor-vr-")
                preset_file = Path(self._folder) / "preset.json"
                preset.save(preset_file)
            # Shared memory, like the temporary folder, is only known to be shared unwrapped.
            share = self.share_tiles and not through_link
            if self.tiles is not None and self.tiles.start(share) is not None:
                scene = {**(scene or {}), "texture_size": self.tiles.size}
            command = viewer_command(preset_file, desktop, scene, tuple(self.extra_args))
        except ValueError as error:  # PresetError included
            self._end(-1, f"Cannot start the VR viewer: {error}")
            return
        self._outbox.start(preset, through_link)
        process = self.process = QProcess(self)
        environment = QProcessEnvironment.systemEnvironment()
        environment.insert("PYTHONUNBUFFERED", "1")
        process.setProcessEnvironment(environment)
        process.setProgram(command[0])
        process.setArguments(command[1:])
        # Bound to this process: a stopped viewer's late signals must not reach the next one.
        process.readyReadStandardOutput.connect(partial(self._read_stdout, process))
        process.readyReadStandardError.connect(partial(self._read_stderr, process))
        process.errorOccurred.connect(partial(self._process_error, process))
        process.finished.connect(partial(self._process_finished, process))
        process.started.connect(partial(self._process_started, process))
        self._ready_timer.start(self.ready_timeout_ms)
        process.start()

    def _process_started(self, process: QProcess) -> None:
        if process is self.process:
            self._outbox.write_preset()  # the starting preset, when it is not given as a file
            self.started.emit()

    def stop(self) -> None:
        """Ask the viewer to quit; SIGTERM and then SIGKILL follow if it does not."""
        if self.process is None or self.stopping:
            return
        self._ready_timer.stop()
        self._send({"type": "quit"})
        self.process.closeWriteChannel()
        self._terminate_timer.start()

    def shutdown(self) -> None:
        """End the viewer now (the editor is going away): quit, then kill what is left."""
        if self.process is None:
            return
        if self.process.state() == QProcess.ProcessState.Running:
            self._send({"type": "quit"})
            self.process.closeWriteChannel()
            # A few ms for a clean exit; the viewer also quits by itself at EOF on its stdin.
            if not self.process.waitForFinished(50):
                self.process.kill()
                self.process.waitForFinished(50)
        if self.process is not None:
            self._end(self._exit_status(), "The VR viewer was closed with the editor.")

    def _terminate(self) -> None:
        if self.process is not None:
            self.stop_reason = self.stop_reason or "it did not quit when asked"
            self.process.terminate()
            self._kill_timer.start()

    def _kill(self) -> None:
        if self.process is not None:
            self.process.kill()

    def _ready_timed_out(self) -> None:
        if self.process is None or self.is_ready:
            return
        seconds = self.ready_timeout_ms / 1000
        self.stop_reason = f"it showed nothing within {seconds:g} s"
        self.process.closeWriteChannel()
        self._terminate()

    def _answer_timed_out(self) -> None:
        if self.process is not None and not self.stopping:
            self.responding = False
            seconds = self.answer_timeout_ms / 1000
            self.error.emit(
                f"the viewer has not shown edit #{self.seq} within {seconds:g} s and may be "
                "hanging; Stop VR ends it"
            )

    def _process_error(self, process: QProcess, error: QProcess.ProcessError) -> None:
        if error == QProcess.ProcessError.FailedToStart and process is self.process:
            self._end(
                -1,
                f"Cannot start the VR viewer: {process.program()}: {process.errorString()}. "
                f"Check {WRAPPER_VARIABLE} and {PYTHON_VARIABLE} if they are set.",
            )

    def _process_finished(self, process: QProcess, *_exit) -> None:
        if process is not self.process:
            return
        self._read_stdout(process)
        self._read_stderr(process)
        status = self._exit_status()
        message = describe_exit(status, self.stop_reason, self.is_ready, self.stderr_tail())
        self._end(status, message)

    def _exit_status(self) -> int:
        process = self.process
        if process is None or process.state() != QProcess.ProcessState.NotRunning:
            return -SIGKILL
        if process.exitStatus() == QProcess.ExitStatus.CrashExit:
            # Qt reports the terminating signal as the exit code of a crashed process.
            return -process.exitCode() if process.exitCode() > 0 else -SIGKILL
        return process.exitCode()

    def stderr_tail(self, lines: int = STDERR_LINES_SHOWN) -> str:
        return "\n".join(list(self.stderr_lines)[-lines:])

    def _end(self, status: int, message: str) -> None:
        process, self.process = self.process, None
        timers = (self._ready_timer, self._answer_timer, self._terminate_timer, self._kill_timer)
        for timer in timers:
            timer.stop()
        self._outbox.stop()
        if self.tiles is not None:
            self.tiles.clear()
        self.responding = True
        if process is not None:
            if process.state() != QProcess.ProcessState.NotRunning:
                process.kill()  # only reached from shutdown(), where it was already killed
            process.deleteLater()
        if self._folder is not None:
            shutil.rmtree(self._folder, ignore_errors=True)
            self._folder = None
        self.finished.emit(status, message)

    # -- editor → viewer ----------------------------------------------------------------------

    def send_preset(self, preset: Preset) -> None:
        """Stream a preset (saved or not); sent at most every ``SEND_INTERVAL_MS``, the latest."""
        self._outbox.put_preset(preset)

    def send_time(self, **fields) -> None:
        """Any of ``hours``, ``day_speed`` (simulated hours per real second), ``playing``."""
        self._outbox.put_time(**fields)

    def send_mode(self, mode: str) -> None:
        self._outbox.put_mode(mode)

    def _accepting(self) -> bool:
        return self.process is not None and not self.stopping

    def _preset_sent(self) -> None:
        if self.is_ready and not self._answer_timer.isActive():
            self._answer_timer.start(self.answer_timeout_ms)

    def _send(self, message: dict) -> None:
        if self.process is not None and self.process.state() == QProcess.ProcessState.Running:
            self.process.write(encode(**message).encode("utf-8"))
            self.sent[message["type"]] += 1

    # -- viewer → editor ----------------------------------------------------------------------

    def _read_stdout(self, process: QProcess) -> None:
        if process is not self.process:
            return
        self._stdout += bytes(process.readAllStandardOutput().data())
        *lines, self._stdout = self._stdout.split(b"\n")
        for line in lines:
            if line.strip():
                self._receive(line)

    def _receive(self, line: bytes) -> None:
        try:
            message = decode(line)
            self._dispatch(message)
        except (TypeError, ValueError) as problem:
            self.error.emit(f"the viewer sent a line that is not the link protocol: {problem}")

    def _dispatch(self, message: dict) -> None:
        kind = message["type"]
        if kind == "ready":
            self._ready_timer.stop()
            if self._outbox.unanswered:  # the starting preset went over the link
                self._answer_timer.start(self.answer_timeout_ms)
            self.ready_info = message
            self.ready.emit(message)
            self._outbox.schedule()
        elif kind == "state":
            self.session_state = str(message.get("state", ""))
            self.state.emit(self.session_state)
        elif kind == "applied":
            seq = int(message.get("seq", -1))
            if seq == self.seq:
                self._answer_timer.stop()
            elif self._answer_timer.isActive():
                self._answer_timer.start(self.answer_timeout_ms)  # answering, a newer one is due
            self.responding = True
            self.applied_grains = str(message.get("grains", ""))
            self._outbox.shown(seq)
            self.applied.emit(seq, float(message.get("ms", "nan")))
        elif kind == "time":
            self.time.emit(check_time_fields(message))
        elif kind == "mode":
            self.mode.emit(str(message.get("mode", "")))
        elif kind == "error":
            self.error.emit(str(message.get("message", "")))
        elif kind == "bye":
            self.session_state = "EXITING"
        else:
            raise ValueError(f"unknown message type {kind!r}")

    def _read_stderr(self, process: QProcess) -> None:
        if process is not self.process:
            return
        text = bytes(process.readAllStandardError().data()).decode("utf-8", "replace")
        for line in text.splitlines():
            if line.strip():
                self.stderr_lines.append(line.rstrip())
                print(f"vr: {line.rstrip()}", file=sys.stderr)
