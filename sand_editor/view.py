"""What the user looks at and when: the camera, the clock and the render mode, in one evented
model that the 3D tab, the editor's settings, the editor's VR link and the VR viewer share.

Qt-free and standard library only. The clock has one unit everywhere: ``day_speed`` is simulated
hours per real second (1/3600 is real time, 24 a day a second), kept while the day is paused, so
that playing again resumes at the same speed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

MAX_DAY_SPEED = 24.0  # simulated hours per real second
CLOCK = "clock"  # the source of changes made by the running clock (ViewModel.tick)
TIME_FIELDS = frozenset({"hours", "day_speed", "playing"})  # the clock's fields of ViewState
REAL_TIME = 1.0 / 3600.0  # the day speed of a real day
DEFAULT_DAY_SPEED = 0.25  # what playing a day starts at: a quarter of an hour a second
# The eye's distance from the sand, for the editor's view and every rendered frame alike: a
# grain's width to a field of dunes.
MIN_DISTANCE_M = 1e-3
MAX_DISTANCE_M = 1000.0
MIN_PITCH_DEG = 1.0
MAX_PITCH_DEG = 90.0
# The render modes (sand_editor.render.modes takes them from here, with their help texts).
MODES = ("full", "lambert", "close", "far", "blend", "glints", "normals", "mip", "reference-look")


def wrap_hours(hours: float) -> float:
    """``hours`` on the clock, in [0, 24); not a finite number → midnight."""
    if not math.isfinite(hours):
        return 0.0
    wrapped = hours % 24.0
    return 0.0 if wrapped >= 24.0 else wrapped


def advance(hours: float, seconds: float, day_speed: float) -> float:
    """The clock ``seconds`` of real time later at ``day_speed`` simulated hours a second."""
    if not (math.isfinite(seconds) and seconds > 0 and math.isfinite(day_speed)):
        return wrap_hours(hours)
    return wrap_hours(hours + seconds * day_speed)


def format_time(hours: float) -> str:
    """``HH:MM`` as a clock shows it: the minute under way (10:59:59 is 10:59)."""
    minutes = math.floor(wrap_hours(hours) * 60.0 + 1e-6) % (24 * 60)
    return f"{minutes // 60:02d}:{minutes % 60:02d}"


def _clamp(value: Any, low: float, high: float, default: float) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return default
    if not math.isfinite(number):
        return default
    return min(max(number, low), high)


@dataclass(frozen=True)
class ViewState:
    """One moment of the view: where the camera is, the clock, what is drawn.

    ``exposure`` None means automatic (from the sky); a number is a fixed exposure.
    """

    distance_m: float = 1.0
    pitch_deg: float = 45.0
    heading_deg: float = 0.0
    hours: float = 10.0
    day_speed: float = DEFAULT_DAY_SPEED
    playing: bool = False
    mode: str = "full"
    show_sphere: bool = False
    exposure: float | None = None

    def checked(self) -> ViewState:
        """The same state with every value made valid: clamped into range, wrapped (heading,
        hours) or, where it cannot be read, the default."""
        exposure = self.exposure
        if exposure is not None:
            exposure = _clamp(exposure, 1e-6, 1e6, 1.0)
        return ViewState(
            distance_m=_clamp(self.distance_m, MIN_DISTANCE_M, MAX_DISTANCE_M, 1.0),
            pitch_deg=_clamp(self.pitch_deg, MIN_PITCH_DEG, MAX_PITCH_DEG, 45.0),
            heading_deg=_clamp(self.heading_deg, -1e9, 1e9, 0.0) % 360.0,
            hours=wrap_hours(_clamp(self.hours, -1e9, 1e9, 10.0)),
            day_speed=_clamp(self.day_speed, 0.0, MAX_DAY_SPEED, DEFAULT_DAY_SPEED),
            playing=self.playing is True,
            mode=self.mode if self.mode in MODES else "full",
            show_sphere=self.show_sphere is True,
            exposure=exposure,
        )

    def advanced(self, seconds: float) -> ViewState:
        """The state ``seconds`` of real time later (a paused day stands still)."""
        if not self.playing:
            return self
        return replace(self, hours=advance(self.hours, seconds, self.day_speed))

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> ViewState:
        """A state from stored values: unknown keys are ignored, bad values fall back."""
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in values.items() if k in names}).checked()


Listener = Callable[[ViewState, frozenset, object], None]


class ViewModel:
    """The current ``ViewState`` and who listens to it.

    ``update(**changes)`` validates the changes and tells every listener ``(state, names,
    source)`` once, with the names of the fields that changed (none, no call); ``source`` is
    whoever made the change, so a listener can skip its own. ``blocked()`` silences listeners for
    a block and restores the previous setting after it, whatever happened inside.
    """

    def __init__(self, state: ViewState | None = None) -> None:
        self._state = (state or ViewState()).checked()
        self._listeners: list[Listener] = []
        self._blocked = False
        self._ticked = time.monotonic()

    @property
    def state(self) -> ViewState:
        return self._state

    def connect(self, listener: Listener) -> None:
        self._listeners.append(listener)

    def disconnect(self, listener: Listener) -> None:
        self._listeners.remove(listener)

    @contextmanager
    def blocked(self) -> Iterator[None]:
        previous, self._blocked = self._blocked, True
        try:
            yield
        finally:
            self._blocked = previous

    def update(self, source: object = None, **changes: Any) -> frozenset:
        """Apply ``changes`` (field names of ``ViewState``); returns the names that changed."""
        new = replace(self._state, **changes).checked()
        changed = frozenset(
            f.name
            for f in fields(ViewState)
            if getattr(new, f.name) != getattr(self._state, f.name)
        )
        if not changed:
            return changed
        if changed & TIME_FIELDS:
            self._ticked = time.monotonic()  # the clock runs on from the value just set
        self._state = new
        if not self._blocked:
            for listener in list(self._listeners):
                listener(new, changed, source)
        return changed

    def tick(self, seconds: float | None = None, source: object = CLOCK) -> frozenset:
        """Run the clock on, if the day is playing: by ``seconds`` of real time, or by the time
        since the last tick (or since the clock last changed), so a clock that nobody ticked for
        a while catches up at its next tick."""
        now = time.monotonic()
        if seconds is None:
            seconds = now - self._ticked
        self._ticked = now
        state = self._state
        if not state.playing:
            return frozenset()
        return self.update(source, hours=advance(state.hours, seconds, state.day_speed))
