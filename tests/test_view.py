"""The view model without Qt: validation, events, blocking, the one clock and its formatter."""

from __future__ import annotations

import math
import time

import pytest

from sand_editor.view import (
    CLOCK,
    MAX_DAY_SPEED,
    ViewModel,
    ViewState,
    advance,
    format_time,
    wrap_hours,
)


def test_update_tells_each_listener_once_what_changed_and_who_changed_it():
    model = ViewModel()
    heard = []
    model.connect(lambda state, names, source: heard.append((names, source, state.hours)))
    assert model.update("panel", hours=16.5, mode="far") == {"hours", "mode"}
    assert heard == [(frozenset({"hours", "mode"}), "panel", 16.5)]
    assert model.update("panel", hours=16.5) == frozenset()
    assert len(heard) == 1, "no change, no event"


@pytest.mark.parametrize(
    "changes,field,expected",
    [
        ({"distance_m": math.nan}, "distance_m", 1.0),
        ({"distance_m": 1e9}, "distance_m", 1000.0),
        ({"distance_m": 0.0}, "distance_m", 1e-3),
        ({"pitch_deg": -5}, "pitch_deg", 1.0),
        ({"heading_deg": 725.0}, "heading_deg", 5.0),
        ({"hours": 25.5}, "hours", 1.5),
        ({"hours": math.inf}, "hours", 10.0),
        ({"day_speed": 1e6}, "day_speed", MAX_DAY_SPEED),
        ({"day_speed": "fast"}, "day_speed", 0.25),
        ({"mode": "sparkly"}, "mode", "full"),
        ({"playing": "yes"}, "playing", False),
        ({"exposure": -1.0}, "exposure", 1e-6),
    ],
)
def test_every_value_is_made_valid(changes, field, expected):
    model = ViewModel()
    model.update(**changes)
    assert getattr(model.state, field) == pytest.approx(expected)


def test_blocked_silences_and_restores_the_previous_setting_even_after_an_error():
    model = ViewModel()
    heard = []
    model.connect(lambda *event: heard.append(event))
    with model.blocked():
        with model.blocked():
            model.update(hours=3.0)
        model.update(hours=4.0)  # still blocked: the inner block restored "blocked"
    assert heard == [] and model.state.hours == 4.0
    with pytest.raises(RuntimeError), model.blocked():
        raise RuntimeError
    model.update(hours=5.0)
    assert len(heard) == 1


def test_the_clock_runs_only_while_playing_and_catches_up_when_ticked_late():
    model = ViewModel(ViewState(hours=23.5, day_speed=1.0, playing=False))
    assert model.tick(3600.0) == frozenset() and model.state.hours == 23.5
    model.update(playing=True)
    heard = []
    model.connect(lambda state, names, source: heard.append(source))
    model.tick(1.0)
    assert model.state.hours == pytest.approx(0.5) and heard == [CLOCK]
    time.sleep(0.2)
    model.tick()  # nobody ticked for 0.2 s: the clock has run on all the same
    assert model.state.hours == pytest.approx(0.7, abs=0.05)


def test_one_formatter_shows_the_minute_under_way():
    assert format_time(16.5) == "16:30"
    assert format_time(10 + 59.99 / 60) == "10:59"
    assert format_time(24.0) == "00:00" and format_time(-0.5) == "23:30"
    assert format_time(math.nan) == "00:00"
    assert wrap_hours(48.25) == 0.25 and advance(23.0, 7200.0, 1 / 3600) == pytest.approx(1.0)


def test_states_round_trip_through_stored_values_and_ignore_unknown_keys():
    state = ViewState(distance_m=0.3, hours=6.25, playing=True, mode="glints", exposure=2.0)
    assert ViewState.from_dict({**state.to_dict(), "unknown": 1}) == state
