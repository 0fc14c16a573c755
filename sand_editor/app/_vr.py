"""The editor's side of the VR link: start ``sand-editor vr --control stdio`` as a child process,
stream the preset being edited, the time of day and the mode to it, and turn its answers into Qt
signals (protocol: ``sand_editor.vr.link``). The window's button and bindings are in
``_vr_controls``.

The viewer is a separate process so that a runtime, driver or headset problem can never take the
editor down: whatever the viewer does (crash, hang, refuse to start), the editor says what
happened and stays usable. Nothing here waits on the process on the GUI thread.
"""

from __future__ import annotations

import collections
import os
import shlex
import shutil
import signal
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

from PySide6.QtCore import QObject, QProcess, QProcessEnvironment, QTimer, Signal

from sand_editor.preset import Preset
from sand_editor.vr.link import (
    EXIT_BAD_INPUT,
    EXIT_GRAPHICS,
    EXIT_INTERRUPTED,
    EXIT_LINK_BROKEN,
    EXIT_NO_HEADSET,
    EXIT_NO_RUNTIME,
    EXIT_OK,
    check_time_fields,
    decode,
    encode,
)

WRAPPER_VARIABLE = "SAND_EDITOR_VR_WRAPPER"
# The interpreter that runs the viewer; a wrapper that changes root (tools/monado/run) has its
# own Python, where this process's sys.executable does not exist.
PYTHON_VARIABLE = "SAND_EDITOR_VR_PYTHON"
SEND_INTERVAL_MS = 50  # at most one send per interval: a slider drag sends its latest value
READY_TIMEOUT_MS = 60_000  # first frame: shader compile and grain generation on llvmpipe
ANSWER_TIMEOUT_MS = 30_000  # a preset not on screen by then: the viewer is not responding
QUIT_GRACE_MS = 3000  # after "quit", before SIGTERM
TERMINATE_GRACE_MS = 2000  # after SIGTERM, before SIGKILL
STDERR_LINES_KEPT = 40
STDERR_LINES_SHOWN = 6
LATENCIES_KEPT = 100
# Between what happened and the viewer's last log lines, in the message of ``finished``.
LOG_HEADING = "\n\nLast lines from the viewer:\n"

EXIT_MEANINGS = {
    EXIT_BAD_INPUT: "the viewer refused its input (preset or arguments)",
    EXIT_NO_RUNTIME: "no OpenXR runtime is installed or active",
    EXIT_NO_HEADSET: "the OpenXR runtime has no headset ready (none found, or it was lost)",
    EXIT_GRAPHICS: "the viewer could not set up graphics (no OpenGL context, or the runtime "
    "refused the session)",
    EXIT_LINK_BROKEN: "the viewer lost its link to the editor (reading the editor's messages "
    "failed)",
    EXIT_INTERRUPTED: "the viewer was interrupted",
}
FIXES = {
    EXIT_NO_RUNTIME: "Install and activate an OpenXR runtime such as SteamVR, Monado or WiVRn "
    "(make it the active runtime in its settings, or point XR_RUNTIME_JSON at its manifest), "
    "then press View in VR again.",
    EXIT_NO_HEADSET: "Connect the headset and turn it on (for WiVRn or ALVR, start the app on "
    "the headset), make sure the runtime shows it as ready, then press View in VR again.",
}


# Signal numbers by name, where the platform has them (Windows has no SIGKILL or SIGBUS).
_SIGKILL = int(getattr(signal, "SIGKILL", 9))
_CRASH_SIGNALS = frozenset(
    int(getattr(signal, name))
    for name in ("SIGSEGV", "SIGBUS", "SIGABRT", "SIGILL", "SIGFPE")
    if hasattr(signal, name)
)


def exit_meaning(status: int) -> str:
    """What an exit status of ``sand-editor vr`` means, in words; negative: killed by a signal."""
    if status < 0:
        name = _signal_name(-status)
        if -status == _SIGKILL:
            return (
                f"the viewer was killed ({name}: by another program, or by the system when "
                "memory ran out)"
            )
        if -status in _CRASH_SIGNALS:
            return f"the viewer crashed ({name})"
        return f"the viewer was ended by {name}"
    if status == EXIT_OK:
        return "the viewer closed"
    return EXIT_MEANINGS.get(status, f"the viewer stopped with exit status {status}")


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def viewer_command(
    preset_file: Path | None,
    desktop: bool,
    scene: dict | None = None,
    extra_args: tuple[str, ...] = (),
) -> list[str]:
    """The command line that starts the viewer, wrapper first; without ``preset_file`` the
    viewer starts on its default preset.

    ``scene`` holds what the viewer starts with: ``hours``, ``day_speed`` (simulated hours per
    real second, 0 when the day is paused) and ``mode``, each optional.

    Raises
    ------
    ValueError
        When the wrapper variable cannot be split like a shell command line.
    """
    try:
        wrapper = shlex.split(os.environ.get(WRAPPER_VARIABLE, ""))
    except ValueError as error:
        raise ValueError(f"{WRAPPER_VARIABLE}: {error}") from None
    python = os.environ.get(PYTHON_VARIABLE) or sys.executable
    command = [*wrapper, python, "-m", "sand_editor", "vr", "--control", "stdio"]
    if desktop:
        command.append("--desktop")
    scene = scene or {}
    if "hours" in scene:
        minutes = round(scene["hours"] * 60.0) % (24 * 60)
        command += ["--time", f"{minutes // 60:02d}:{minutes % 60:02d}"]
    if scene.get("day_speed"):
        command += ["--day-speed", f"{scene['day_speed']:.6g}"]
    if "mode" in scene:
        command += ["--mode", scene["mode"]]
    command += extra_args
    return command if preset_file is None else [*command, str(preset_file)]


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

    def __init__(self, parent: QObject | None = None):
        super().__init__(parent)
        self.ready_timeout_ms = READY_TIMEOUT_MS
        self.extra_args: tuple[str, ...] = ()  # more viewer options, e.g. ("--render-scale", "0.5")
        self.process: QProcess | None = None
        self.desktop = False
        self.ready_info: dict | None = None
        self.session_state = ""
        self.stderr_lines: collections.deque[str] = collections.deque(maxlen=STDERR_LINES_KEPT)
        self.seq = 0
        self.sent: collections.Counter[str] = collections.Counter()  # messages by type
        # seq → ms from the edit to its "applied", for the latest LATENCIES_KEPT presets shown.
        self.latency_ms: dict[int, float] = {}
        self._edit_times: dict[int, float] = {}  # seq → perf_counter() of the edit, until shown
        self._pending_preset: Preset | None = None
        self._pending_since = 0.0
        self._last_flush = 0.0  # perf_counter() of the last send
        self._pending: dict[str, dict] = {}  # other messages by type, the latest of each
        self._sent_preset: Preset | None = None
        self._stdout = b""
        self._folder: str | None = None
        # Why the editor ended the viewer itself (it hung); None when it exited on its own.
        self.stop_reason: str | None = None
        self._send_timer = QTimer(self, singleShot=True)
        self._send_timer.timeout.connect(self._flush)
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
    def unanswered(self) -> int:
        """Presets sent and neither shown nor superseded yet."""
        return len(self._edit_times)

    @property
    def last_sent_preset(self) -> Preset | None:
        """The preset the viewer was last given (on its command line or over the link)."""
        return self._sent_preset

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
        self._pending_preset = None
        self._pending.clear()
        self._edit_times.clear()
        # A wrapper may run the viewer where this machine's temporary folder is not (a chroot,
        # a container): the preset then goes over the link, as its first message.
        through_link = bool(os.environ.get(WRAPPER_VARIABLE, "").strip())
        preset_file = None
        try:
            if not through_link:
                self._folder = tempfile.mkdtemp(prefix="sand-editor-vr-")
                preset_file = Path(self._folder) / "preset.json"
                preset.save(preset_file)
            command = viewer_command(preset_file, desktop, scene, tuple(self.extra_args))
        except ValueError as error:  # PresetError included
            self._end(-1, f"Cannot start the VR viewer: {error}")
            return
        self._sent_preset = None
        if through_link:
            self.send_preset(preset)
        else:
            self._sent_preset = preset
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
            if self._pending_preset is not None:
                self._send_preset()  # the starting preset, when it is not given as a file
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
        self._end(status, self._describe_exit(status))

    def _exit_status(self) -> int:
        process = self.process
        if process is None or process.state() != QProcess.ProcessState.NotRunning:
            return -_SIGKILL
        if process.exitStatus() == QProcess.ExitStatus.CrashExit:
            # Qt reports the terminating signal as the exit code of a crashed process.
            return -process.exitCode() if process.exitCode() > 0 else -_SIGKILL
        return process.exitCode()

    def _describe_exit(self, status: int) -> str:
        sentence = exit_meaning(status)
        if self.stop_reason is not None:
            ending = _signal_name(-status) if status < 0 else f"exit status {status}"
            sentence = f"the viewer was stopped because {self.stop_reason} (it ended with {ending})"
        elif status == EXIT_OK and not self.is_ready:
            sentence = "the viewer closed before it showed anything"
        message = sentence[0].upper() + sentence[1:] + "."
        if status in FIXES:
            message += " " + FIXES[status]
        tail = self.stderr_tail()
        if tail and (status != EXIT_OK or self.stop_reason is not None):
            message += LOG_HEADING + tail
        return message

    def stderr_tail(self, lines: int = STDERR_LINES_SHOWN) -> str:
        return "\n".join(list(self.stderr_lines)[-lines:])

    def _end(self, status: int, message: str) -> None:
        process, self.process = self.process, None
        timers = (self._ready_timer, self._answer_timer, self._terminate_timer, self._kill_timer)
        for timer in (*timers, self._send_timer):
            timer.stop()
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
        if self._pending_preset is None:
            self._pending_since = time.perf_counter()
        self._pending_preset = preset
        self._schedule()

    def send_time(self, **fields) -> None:
        """Any of ``hours``, ``day_speed`` (simulated hours per real second), ``playing``."""
        merged = self._pending.get("time", {"type": "time"})
        merged.update(fields)
        self._pending["time"] = merged
        self._schedule()

    def send_mode(self, mode: str) -> None:
        self._pending["mode"] = {"type": "mode", "mode": mode}
        self._schedule()

    def _schedule(self) -> None:
        # Before "ready" everything waits; the latest of each kind is sent once the viewer shows.
        if not self.is_ready or self._send_timer.isActive():
            return
        # The first change after a pause goes at once; during a drag one per interval follows.
        wait_ms = SEND_INTERVAL_MS - (time.perf_counter() - self._last_flush) * 1000.0
        if wait_ms <= 0:
            self._flush()
        else:
            self._send_timer.start(max(1, round(wait_ms)))

    def _flush(self) -> None:
        if self.process is None or not self.is_ready or self.stopping:
            return
        self._last_flush = time.perf_counter()
        self._send_preset()
        for message in self._pending.values():
            self._send(message)
        self._pending.clear()

    def _send_preset(self) -> None:
        preset, self._pending_preset = self._pending_preset, None
        if preset is not None and preset != self._sent_preset:
            self.seq += 1
            self._edit_times[self.seq] = self._pending_since
            self._sent_preset = preset
            self._send({"type": "preset", "preset": preset.to_dict(), "seq": self.seq})
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
            if self._edit_times:  # the starting preset went over the link
                self._answer_timer.start(self.answer_timeout_ms)
            self.ready_info = message
            self.ready.emit(message)
            self._schedule()
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
            edited = self._edit_times.pop(seq, None)
            if edited is not None:
                self.latency_ms[seq] = (time.perf_counter() - edited) * 1000.0
            # The viewer skips presets superseded before it started on them: never shown.
            for skipped in [s for s in self._edit_times if s < seq]:
                del self._edit_times[skipped]
            for oldest in list(self.latency_ms)[: max(0, len(self.latency_ms) - LATENCIES_KEPT)]:
                del self.latency_ms[oldest]
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
