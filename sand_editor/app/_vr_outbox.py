"""The editor's messages for the viewer, coalesced: a slider drag changes the preset many times a
second, and the viewer gets at most one send every ``SEND_INTERVAL_MS``, with the latest of each
kind. Each preset sent is numbered and timed from the edit until the viewer shows it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from PySide6.QtCore import QObject, QTimer, Signal

from sand_editor.preset import Preset

SEND_INTERVAL_MS = 50  # at most one send per interval: a slider drag sends its latest value
HOLD_RETRY_MS = 50  # a preset waiting for the editor's tile of its grains asks again this often
LATENCIES_KEPT = 100


class Outbox(QObject):
    """What waits to go to the viewer: the latest preset, the time fields merged, the latest mode.

    ``write(message)`` puts one message on the link. Sends wait until ``ready()`` is true (the
    viewer has shown its first frame) and are skipped while ``accepting()`` is false (no process,
    or it is being stopped), keeping what waits; ``write_preset`` sends the waiting preset
    regardless. With ``tiles`` (``SharedTiles``), a preset goes with the editor's tile of its
    grains, and waits for that tile while it is being made.

    Signals
    -------
    preset_sent()
        A preset was given to ``write``; ``seq`` is its number.
    """

    preset_sent = Signal()

    def __init__(
        self,
        write: Callable[[dict], None],
        ready: Callable[[], bool],
        accepting: Callable[[], bool],
        parent: QObject | None = None,
    ):
        super().__init__(parent)
        self.tiles = None  # a SharedTiles, when the editor hands its tiles over
        self._write = write
        self._ready = ready
        self._accepting = accepting
        self.seq = 0  # the number of the latest preset sent
        # seq → ms from the edit to its "applied", for the latest LATENCIES_KEPT presets shown.
        self.latency_ms: dict[int, float] = {}
        self._edit_times: dict[int, float] = {}  # seq → perf_counter() of the edit, until shown
        self._pending_preset: Preset | None = None
        self._pending_since = 0.0
        self._last_flush = 0.0  # perf_counter() of the last send
        self._pending: dict[str, dict] = {}  # other messages by type, the latest of each
        self._sent_preset: Preset | None = None
        self._timer = QTimer(self, singleShot=True)
        self._timer.timeout.connect(self._flush)

    @property
    def unanswered(self) -> int:
        """Presets sent and neither shown nor superseded yet."""
        return len(self._edit_times)

    @property
    def last_sent_preset(self) -> Preset | None:
        """The preset the viewer was last given (on its command line or over the link)."""
        return self._sent_preset

    def clear(self) -> None:
        """Drop what waits and forget the presets not shown yet."""
        self._pending_preset = None
        self._pending.clear()
        self._edit_times.clear()
        if self.tiles is not None:
            self.tiles.clear()

    def start(self, preset: Preset, through_link: bool) -> None:
        """A viewer starts on ``preset``: on its command line, or (``through_link``) as the first
        message over the link, sent by ``write_preset`` once the process runs."""
        self._sent_preset = None if through_link else preset
        if through_link:
            self.put_preset(preset)

    def stop(self) -> None:
        """Send nothing more until the next change; what waits stays."""
        self._timer.stop()

    def put_preset(self, preset: Preset) -> None:
        """Send a preset (saved or not) at the next send, unless a newer one comes first."""
        if self._pending_preset is None:
            self._pending_since = time.perf_counter()
        self._pending_preset = preset
        self.schedule()

    def put_time(self, **fields) -> None:
        """Any of ``hours``, ``day_speed``, ``playing``, merged with those still waiting."""
        merged = self._pending.get("time", {"type": "time"})
        merged.update(fields)
        self._pending["time"] = merged
        self.schedule()

    def put_mode(self, mode: str) -> None:
        self._pending["mode"] = {"type": "mode", "mode": mode}
        self.schedule()

    def schedule(self) -> None:
        """Send what waits now, or once ``SEND_INTERVAL_MS`` has passed since the last send."""
        # Before "ready" everything waits; the latest of each kind is sent once the viewer shows.
        if not self._ready() or self._timer.isActive():
            return
        # The first change after a pause goes at once; during a drag one per interval follows.
        wait_ms = SEND_INTERVAL_MS - (time.perf_counter() - self._last_flush) * 1000.0
        if wait_ms <= 0:
            self._flush()
        else:
            self._timer.start(max(1, round(wait_ms)))

    def _flush(self) -> None:
        if not self._accepting() or not self._ready():
            return
        self._last_flush = time.perf_counter()
        self.write_preset()
        for message in self._pending.values():
            self._write(message)
        self._pending.clear()

    def write_preset(self) -> None:
        """Send the waiting preset now, unless the viewer has it already."""
        preset = self._pending_preset
        if preset is None or preset == self._sent_preset:
            self._pending_preset = None
            return
        extra = {}
        if self.tiles is not None:
            held_s = time.perf_counter() - self._pending_since
            extra = self.tiles.fields(preset, self._sent_preset, self.seq + 1, held_s)
            if extra is None:  # its grains are being made: ask again shortly
                self._timer.start(HOLD_RETRY_MS)
                return
        self._pending_preset = None
        self.seq += 1
        self._edit_times[self.seq] = self._pending_since
        self._sent_preset = preset
        self._write({"type": "preset", "preset": preset.to_dict(), "seq": self.seq, **extra})
        self.preset_sent.emit()

    def shown(self, seq: int) -> None:
        """The viewer shows preset ``seq``: time it, and forget those sent before it."""
        if self.tiles is not None:
            self.tiles.shown(seq)
        edited = self._edit_times.pop(seq, None)
        if edited is not None:
            self.latency_ms[seq] = (time.perf_counter() - edited) * 1000.0
        # The viewer skips presets superseded before it started on them: never shown.
        for skipped in [s for s in self._edit_times if s < seq]:
            del self._edit_times[skipped]
        for oldest in list(self.latency_ms)[: max(0, len(self.latency_ms) - LATENCIES_KEPT)]:
            del self.latency_ms[oldest]
