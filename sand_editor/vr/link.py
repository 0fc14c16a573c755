"""The editor ↔ viewer link: JSON objects, one per line, on the viewer's stdin and stdout.

The editor imports the constants and ``encode``/``decode`` from here, so this module imports
nothing of OpenXR, OpenGL or Qt.

editor → viewer: ``preset`` (whole preset dict, ``seq``, and optionally ``grains``: ``shm``, the
name of a shared-memory segment holding the editor's finished tile of this preset's grains, and
``size``), ``time`` (``hours``, ``day_speed``, ``playing``, any subset), ``mode``, ``quit``; EOF on
stdin means quit.
viewer → editor: ``ready``, ``state``, ``applied`` (``seq``, ``ms``, ``grains``: ``editor`` when
it shows the editor's tile, ``viewer`` when it made the grains, ``kept`` when none were needed),
``time``, ``mode``, ``error``, ``bye``.
"""

from __future__ import annotations

import json
import os
import queue
import sys
import threading
from typing import IO, Any

from sand_editor.generator.shared import NAME_PATTERN, NAME_RULE
from sand_editor.generator.sizes import SHARED_SIZES
from sand_editor.untrusted import bounded_number, deeper_than, printable, shorten
from sand_editor.view import MAX_DAY_SPEED

# Exit statuses of ``sand-editor vr``.
EXIT_OK = 0
EXIT_BAD_INPUT = 1
EXIT_NO_RUNTIME = 3
EXIT_NO_HEADSET = 4
EXIT_GRAPHICS = 5
EXIT_LINK_BROKEN = 6  # reading the editor's link failed (not EOF, which means quit)
EXIT_INTERRUPTED = 130

# Bounds on what a line may hold; a line past them gets an error back, the link goes on.
MAX_LINE_BYTES = 2 << 20  # a preset message is a few kilobytes; preset files stop at 1 MiB
MAX_DEPTH = 16  # a preset message nests five deep
MAX_NUMBER_CHARS = 100  # Python refuses integers of over 4300 digits; refuse far sooner
MAX_ERROR_CHARS = 300  # an error message sent back, whatever the line held
MAX_SEQ = 2**53  # sequence numbers are integers a JSON reader in any language keeps exactly

EDITOR_MESSAGES = frozenset({"preset", "time", "mode", "move", "press", "quit"})
VIEWER_MESSAGES = frozenset({"ready", "state", "applied", "time", "mode", "error", "bye"})


class LinkError(ValueError):
    """A line that is not a link message: not UTF-8, not JSON, over a bound, not an object, or
    without a ``type``; or a message field of the wrong type or out of range."""


def error_text(text: str) -> str:
    """An error message safe to send back: one line (control characters escaped), bounded."""
    return shorten(printable(text), MAX_ERROR_CHARS)


def encode(type: str, **fields: Any) -> str:  # noqa: A002 - the protocol's field name
    """One message as a line of JSON (with its newline), in ASCII: it reads the same whatever
    the encoding of the pipe's two ends."""
    return json.dumps({"type": type, **fields}, ensure_ascii=True, allow_nan=False) + "\n"


_parse_int = bounded_number(int, MAX_NUMBER_CHARS, LinkError)
_parse_float = bounded_number(float, MAX_NUMBER_CHARS, LinkError)


def decode(line: str | bytes) -> dict:
    """The message of one line; ``LinkError`` names what is wrong with it (and nothing else is
    raised, whatever the line holds)."""
    if isinstance(line, bytes):
        if len(line) > MAX_LINE_BYTES:
            raise LinkError(f"a line of {len(line)} bytes; allowed {MAX_LINE_BYTES}")
        try:
            line = line.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise LinkError(
                f"not UTF-8: byte 0x{line[exc.start]:02x} at offset {exc.start}"
            ) from None
    try:
        message = json.loads(line, parse_int=_parse_int, parse_float=_parse_float)
    except json.JSONDecodeError as exc:
        raise LinkError(f"not JSON: {exc.msg} at column {exc.colno}") from None
    except RecursionError:
        raise LinkError(f"nested more than {MAX_DEPTH} deep") from None
    if deeper_than(message, MAX_DEPTH):
        raise LinkError(f"nested more than {MAX_DEPTH} deep")
    if not isinstance(message, dict):
        raise LinkError(f"expected a JSON object, got {type(message).__name__}")
    if not isinstance(message.get("type"), str):
        raise LinkError("message has no string field 'type'")
    return message


def check_seq(message: dict) -> int | None:
    """A message's ``seq``: absent or null, or an integer from 0 to 2**53."""
    seq = message.get("seq")
    if seq is None:
        return None
    if isinstance(seq, bool) or not isinstance(seq, int) or not 0 <= seq <= MAX_SEQ:
        shown = shorten(repr(seq), 40) if isinstance(seq, (int, float, str)) else type(seq).__name__
        raise LinkError(f"seq must be null or an integer from 0 to 2**53, got {shown}")
    return seq


def check_grains(message: dict) -> tuple[str, int] | None:
    """A preset message's ``grains``: absent or null, or ``{"shm": name, "size": pixels}``."""
    grains = message.get("grains")
    if grains is None:
        return None
    if not isinstance(grains, dict):
        raise LinkError(f"grains must be an object or null, got {type(grains).__name__}")
    name, size = grains.get("shm"), grains.get("size")
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        shown = shorten(repr(name), 40) if isinstance(name, str) else type(name).__name__
        raise LinkError(f"grains.shm must be {NAME_RULE}, got {shown}")
    if isinstance(size, bool) or size not in SHARED_SIZES:
        scalar = isinstance(size, int | float | str)
        shown = shorten(repr(size), 40) if scalar else type(size).__name__
        allowed = ", ".join(map(str, SHARED_SIZES))
        raise LinkError(f"grains.size must be one of {allowed}, got {shown}")
    return name, int(size)


def check_time_fields(message: dict) -> dict:
    """The valid fields of a ``time`` message (``hours``, ``day_speed``, ``playing``); raises
    ``LinkError`` naming a field that is out of range or of the wrong type."""
    fields = {}
    if "hours" in message:
        fields["hours"] = _number(message, "time", "hours", 0.0, 24.0, upper_open=True)
    if "day_speed" in message:
        fields["day_speed"] = _number(message, "time", "day_speed", 0.0, MAX_DAY_SPEED)
    if "playing" in message:
        fields["playing"] = _flag(message, "time", "playing")
    return fields


MAX_MOVE_M = 1.0e5  # a teleport's target, metres from the world's origin


def check_move(message: dict) -> dict:
    """The valid fields of a ``move`` message: ``to`` ([x, z], world metres: teleport there),
    ``turn_degrees`` (turn about the head, in [−180, 180]) and ``bring_bench`` (true: the
    workbench comes along); raises ``LinkError`` naming a bad field."""
    fields = {}
    if "to" in message:
        to = message["to"]
        if not (isinstance(to, list) and len(to) == 2 and all(_is_number(v) for v in to)
                and all(abs(v) <= MAX_MOVE_M for v in to)):  # fmt: skip
            shown = shorten(repr(to), 60)
            raise LinkError(f"move.to must be [x, z], numbers within ±{MAX_MOVE_M:g}, got {shown}")
        fields["to"] = (float(to[0]), float(to[1]))
    if "turn_degrees" in message:
        fields["turn_degrees"] = _number(message, "move", "turn_degrees", -180.0, 180.0)
    if "bring_bench" in message:
        fields["bring_bench"] = _flag(message, "move", "bring_bench")
    if not fields:
        raise LinkError("move needs at least one of: to, turn_degrees, bring_bench")
    return fields


def _number(message: dict, kind: str, name: str, low: float, high: float,
            upper_open: bool = False) -> float:  # fmt: skip
    """Field ``name`` of a ``kind`` message as a float in [low, high] (or [low, high))."""
    value = message[name]
    inside = _is_number(value) and low <= value and (value < high if upper_open else value <= high)
    if not inside:
        bounds = f"[{low:g}, {high:g}{')' if upper_open else ']'}"
        raise LinkError(f"{kind}.{name} must be a number in {bounds}, got {value!r}")
    return float(value)


def _flag(message: dict, kind: str, name: str) -> bool:
    """Field ``name`` of a ``kind`` message, which must be true or false."""
    value = message[name]
    if not isinstance(value, bool):
        raise LinkError(f"{kind}.{name} must be true or false, got {value!r}")
    return value


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and value == value


_TOO_LONG = object()  # what the line splitter yields for a line past MAX_LINE_BYTES


def _fd_lines(fd: int):
    """Lines (bytes, with their newline) read from a file descriptor with ``os.read``: no
    Python buffer and so no lock that a reader blocked at exit would hold. A line longer than
    ``MAX_LINE_BYTES`` is dropped to its end and stands as ``_TOO_LONG``."""
    pending = bytearray()
    skipping = False
    while chunk := os.read(fd, 1 << 16):
        start = 0
        while (end := chunk.find(b"\n", start)) >= 0:
            if skipping:
                skipping = False
            else:
                pending += chunk[start : end + 1]
                yield _TOO_LONG if len(pending) > MAX_LINE_BYTES + 1 else bytes(pending)
            pending.clear()
            start = end + 1
        if not skipping:
            pending += chunk[start:]
            if len(pending) > MAX_LINE_BYTES:
                yield _TOO_LONG
                pending.clear()
                skipping = True
    if pending and not skipping:
        yield bytes(pending)


def _stream_lines(stream):
    """Lines of a file object without a descriptor (an in-memory stream in tests)."""
    for line in stream:
        yield _TOO_LONG if len(line) > MAX_LINE_BYTES + 1 else line


class StdioLink:
    """The viewer's end: a daemon thread reads lines from ``stdin`` into a queue.

    ``poll()`` returns what was received since the last call without blocking: a message dict
    for each good line, a ``LinkError`` for each bad one (for the caller to answer); ``send(**
    message)`` writes one line and flushes, from any thread; ``closed`` turns true at EOF, and
    ``broken`` holds the reason when reading failed instead (the link itself broke).

    Lines are read as bytes from the descriptor, whatever the locale's encoding; a line over
    ``MAX_LINE_BYTES`` is skipped to its end and answered with an error.
    """

    def __init__(self, stdin: IO | None = None, stdout: IO[str] | None = None) -> None:
        self._stdin = stdin if stdin is not None else sys.stdin
        self._stdout = stdout if stdout is not None else sys.stdout
        self._messages: queue.SimpleQueue[dict | LinkError] = queue.SimpleQueue()
        self._write_lock = threading.Lock()
        self.closed = False
        self.broken: str | None = None
        # Set by the reader at "quit" or at EOF: the start-up, which polls nothing, asks it.
        self.quit_asked = False
        self._reader = threading.Thread(target=self._read, name="vr-link-reader", daemon=True)
        self._reader.start()

    def _lines(self):
        try:
            fd = self._stdin.fileno()
        except (AttributeError, OSError, ValueError):
            return _stream_lines(self._stdin)
        return _fd_lines(fd)

    def _read(self) -> None:
        try:
            for line in self._lines():
                if line is _TOO_LONG:
                    self._messages.put(LinkError(f"a line over {MAX_LINE_BYTES} bytes; skipped"))
                    continue
                if not line.strip():
                    continue
                try:
                    message = decode(line)
                except LinkError as exc:
                    self._messages.put(exc)
                    continue
                self._messages.put(message)
                if message.get("type") == "quit":
                    self.quit_asked = True
        except BaseException as exc:  # noqa: BLE001 - reported by the frame loop, not lost
            self.broken = f"{type(exc).__name__}: {exc}"
        finally:
            self.closed = True
            self.quit_asked = True  # EOF means quit

    def poll(self) -> list[dict | LinkError]:
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
    broken = None
    quit_asked = False

    def poll(self) -> list[dict]:
        return []

    def send(self, **message: Any) -> bool:
        return True
