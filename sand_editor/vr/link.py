"""The editor ↔ viewer link: JSON objects, one per line, on the viewer's stdin and stdout.

The editor imports the constants and ``encode``/``decode`` from here, so this module imports
nothing of OpenXR, OpenGL or Qt.

editor → viewer: ``preset`` (whole preset dict, ``seq``), ``time`` (``hours``, ``day_speed``,
``playing``, any subset), ``mode``, ``quit``; EOF on stdin means quit.
viewer → editor: ``ready``, ``state``, ``applied``, ``time``, ``mode``, ``error``, ``bye``.
"""

from __future__ import annotations

import json
import queue
import sys
import threading
from typing import IO, Any

# Exit statuses of ``sand-editor vr``.
EXIT_OK = 0
EXIT_BAD_INPUT = 1
EXIT_NO_RUNTIME = 3
EXIT_NO_HEADSET = 4
EXIT_GRAPHICS = 5
EXIT_INTERRUPTED = 130

EDITOR_MESSAGES = frozenset({"preset", "time", "mode", "quit"})
VIEWER_MESSAGES = frozenset({"ready", "state", "applied", "time", "mode", "error", "bye"})
MAX_DAY_SPEED = 24.0  # simulated hours per real second


class LinkError(ValueError):
    """A line that is not a link message: not JSON, not an object, or without a ``type``."""


def encode(type: str, **fields: Any) -> str:  # noqa: A002 - the protocol's field name
    """One message as a line of JSON (with its newline)."""
    return json.dumps({"type": type, **fields}, ensure_ascii=False, allow_nan=False) + "\n"


def decode(line: str | bytes) -> dict:
    """The message of one line; ``LinkError`` names what is wrong with it."""
    if isinstance(line, bytes):
        line = line.decode("utf-8", errors="replace")
    try:
        message = json.loads(line)
    except json.JSONDecodeError as exc:
        raise LinkError(f"not JSON: {exc.msg} at column {exc.colno}") from None
    if not isinstance(message, dict):
        raise LinkError(f"expected a JSON object, got {type(message).__name__}")
    if not isinstance(message.get("type"), str):
        raise LinkError("message has no string field 'type'")
    return message


def check_time_fields(message: dict) -> dict:
    """The valid fields of a ``time`` message (``hours``, ``day_speed``, ``playing``); raises
    ``LinkError`` naming a field that is out of range or of the wrong type."""
    fields = {}
    if "hours" in message:
        hours = message["hours"]
        if not _is_number(hours) or not 0.0 <= hours < 24.0:
            raise LinkError(f"time.hours must be a number in [0, 24), got {hours!r}")
        fields["hours"] = float(hours)
    if "day_speed" in message:
        speed = message["day_speed"]
        if not _is_number(speed) or not 0.0 <= speed <= MAX_DAY_SPEED:
            raise LinkError(
                f"time.day_speed must be a number in [0, {MAX_DAY_SPEED:g}], got {speed!r}"
            )
        fields["day_speed"] = float(speed)
    if "playing" in message:
        playing = message["playing"]
        if not isinstance(playing, bool):
            raise LinkError(f"time.playing must be true or false, got {playing!r}")
        fields["playing"] = playing
    return fields


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and value == value


class StdioLink:
    """The viewer's end: a daemon thread reads lines from ``stdin`` into a queue.

    ``poll()`` returns the messages received since the last call without blocking (a line that
    is not a message comes back as ``{"type": "error", ...}`` from ``decode``'s complaint, for
    the caller to answer); ``send(**message)`` writes one line and flushes, from any thread;
    ``closed`` turns true at EOF.
    """

    def __init__(self, stdin: IO[str] | None = None, stdout: IO[str] | None = None) -> None:
        self._stdin = stdin if stdin is not None else sys.stdin
        self._stdout = stdout if stdout is not None else sys.stdout
        self._messages: queue.SimpleQueue[dict] = queue.SimpleQueue()
        self._write_lock = threading.Lock()
        self.closed = False
        self._reader = threading.Thread(target=self._read, name="vr-link-reader", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        try:
            for line in self._stdin:
                if not line.strip():
                    continue
                try:
                    self._messages.put(decode(line))
                except LinkError as exc:
                    self._messages.put({"type": "_invalid", "message": str(exc)})
        except (OSError, ValueError):
            pass  # stdin closed under us: the same as EOF
        finally:
            self.closed = True

    def poll(self) -> list[dict]:
        received = []
        while True:
            try:
                received.append(self._messages.get_nowait())
            except queue.Empty:
                return received

    def send(self, **message: Any) -> bool:
        """Write one message; False when the editor has gone (broken pipe)."""
        line = encode(**message)
        with self._write_lock:
            try:
                self._stdout.write(line)
                self._stdout.flush()
            except (OSError, ValueError):
                return False
        return True


class NullLink:
    """No editor attached: messages go nowhere, nothing arrives."""

    closed = False

    def poll(self) -> list[dict]:
        return []

    def send(self, **message: Any) -> bool:
        return True
