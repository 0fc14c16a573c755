"""Getting about: the tracking space in the world, the teleport arc onto the dunes, snap turns
and the comfort vignette — with the real dune terrain, and at the hard cases (grazing throws,
straight up and down, hands under the ground, non-finite input)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sand_editor.render.terrain import DuneTerrain
from sand_editor.vr.actions import HandInput, InputState
from sand_editor.vr.locomotion import (
    SNAP_TURN_DEG,
    VIGNETTE_S,
    Locomotion,
    TrackingOrigin,
    teleport_arc,
)
from sand_editor.vr.xrmath import Pose

TERRAIN = DuneTerrain()
HEAD = np.array([0.2, 1.6, 0.1])


def _flat(x, z):
    return np.zeros(np.broadcast(x, z).shape)


def test_the_arc_lands_on_flat_ground_where_a_ballistic_throw_lands():
    points, landing = teleport_arc((0.0, 1.0, 0.0), (0.0, 1.0, -1.0), _flat)
    assert landing is not None and landing[1] == pytest.approx(0.0, abs=1e-9)
    v = 16.0 / math.sqrt(2)
    t = (v + math.sqrt(v * v + 2 * 9.81 * 1.0)) / 9.81
    assert -landing[2] == pytest.approx(v * t, rel=2e-3)
    assert landing[0] == pytest.approx(0.0, abs=1e-9)
    assert np.all(points[:-1, 1] >= -1e-9)  # the drawn arc stays above the ground


def test_the_arc_meets_the_dunes_on_their_surface():
    start = np.array([3.0, float(TERRAIN.height(3.0, -2.0)) + 1.2, -2.0])
    _, landing = teleport_arc(start, (0.3, 0.2, -1.0), TERRAIN.height)
    assert landing is not None
    assert landing[1] == pytest.approx(float(TERRAIN.height(landing[0], landing[2])), abs=1e-6)
    assert np.linalg.norm(landing - start) > 5.0


def test_hard_throws_stay_finite():
    for direction in [(0, -1, 0), (0, 1, 0), (1, 0, 0), (0, 0, 0), (np.nan, 0, 1), (1e-12, 0, 0)]:
        points, landing = teleport_arc((0.0, 1.0, 0.0), direction, _flat)
        assert np.all(np.isfinite(points))
        assert landing is None or np.all(np.isfinite(landing))
    # Straight up comes straight down.
    _, landing = teleport_arc((0.0, 1.0, 0.0), (0, 1, 0), _flat)
    np.testing.assert_allclose(landing, (0, 0, 0), atol=1e-6)
    # A hand under the ground throws nothing.
    assert teleport_arc((0.0, -1.0, 0.0), (0, 0, -1), _flat)[1] is None


def test_teleporting_puts_the_head_above_the_target_at_its_height_over_the_floor():
    origin = TrackingOrigin((0.0, 2.0, 0.0), yaw=0.4)
    target = np.array([30.0, 5.0, -40.0])
    moved = origin.teleported(HEAD, target)
    head = moved.point(HEAD)
    np.testing.assert_allclose(head[[0, 2]], target[[0, 2]], atol=1e-9)
    assert head[1] == pytest.approx(target[1] + HEAD[1])
    assert moved.yaw == origin.yaw


def test_a_snap_turn_keeps_the_head_in_place_and_turns_the_view():
    origin = TrackingOrigin((3.0, 1.0, -2.0), yaw=0.0)
    turned = origin.turned(HEAD, math.radians(30))
    np.testing.assert_allclose(turned.point(HEAD), origin.point(HEAD), atol=1e-12)
    forward = turned.pose(Pose(tuple(HEAD))).forward
    assert math.degrees(math.atan2(-forward[0], -forward[2])) == pytest.approx(30.0)
    twelve = origin
    for _ in range(12):
        twelve = twelve.turned(HEAD, math.radians(30))
    assert abs(twelve.yaw) < 1e-9  # a full circle comes back, wrapped


def _locomotion():
    loco = Locomotion(TERRAIN, TrackingOrigin((0.0, float(TERRAIN.height(0, 0)), 0.0)))
    return loco


AIM = Pose.from_yaw_pitch((0.15, 1.2, -0.1), 0.0, math.radians(20))


def _step(loco, previous, state, t):
    return loco.update(previous, state, HEAD, t, lambda hand: False)


def test_stick_forward_aims_and_letting_go_teleports():
    loco = _locomotion()
    rest = InputState(right=HandInput(aim=AIM))
    push = InputState(right=HandInput(stick=(0.0, 1.0), aim=AIM))
    assert _step(loco, rest, push, 0.0) == []
    assert loco.aim is not None and loco.aim.valid and loco.aim.hand == "right"
    target = loco.aim.target
    assert _step(loco, push, rest, 0.1) == ["teleport"]
    np.testing.assert_allclose(loco.origin.point(HEAD)[[0, 2]], target[[0, 2]], atol=1e-9)
    assert loco.aim is None and loco.teleports == 1


def test_a_snap_turn_per_flick_and_none_while_aiming():
    loco = _locomotion()
    rest = InputState()
    flick = InputState(right=HandInput(stick=(0.9, 0.0)))
    assert _step(loco, rest, flick, 0.0) == ["turn"]
    assert _step(loco, flick, flick, 0.1) == []  # held: no second turn
    assert _step(loco, flick, rest, 0.2) == []
    assert _step(loco, rest, InputState(right=HandInput(stick=(-0.9, 0.0))), 0.3) == ["turn"]
    assert loco.turns == 2 and abs(loco.origin.yaw) < 1e-12
    assert math.degrees(abs(loco.origin.turned(HEAD, math.radians(SNAP_TURN_DEG)).yaw)) == (
        pytest.approx(SNAP_TURN_DEG)
    )


def test_the_trigger_aims_away_from_the_panel_only():
    loco = _locomotion()
    rest = InputState(left=HandInput(aim=AIM))
    pull = InputState(left=HandInput(select=1.0, aim=AIM))
    loco.update(rest, pull, HEAD, 0.0, lambda hand: True)  # on the panel: a press, no arc
    assert loco.aim is None
    loco.update(rest, pull, HEAD, 0.0, lambda hand: False)
    assert loco.aim is not None and loco.aim.hand == "left"
    assert loco.update(pull, rest, HEAD, 0.1, lambda hand: False) == ["teleport"]


def test_refused_ground_does_not_teleport():
    loco = _locomotion()
    loco.blocked = lambda point: True  # as the desk refuses a landing in it
    push = InputState(right=HandInput(stick=(0.0, 1.0), aim=AIM))
    _step(loco, InputState(), push, 0.0)
    assert loco.aim is not None and not loco.aim.valid
    assert _step(loco, push, InputState(), 0.1) == []
    assert loco.teleports == 0


def test_the_vignette_closes_at_a_jump_and_opens_again():
    loco = _locomotion()
    assert loco.vignette(5.0) == 0.0
    loco.turn(HEAD, 0.5, 10.0)
    assert loco.vignette(10.0) == pytest.approx(1.0)
    assert 0.0 < loco.vignette(10.0 + VIGNETTE_S / 2) < 1.0
    assert loco.vignette(10.0 + VIGNETTE_S * 1.001) == 0.0


finite = st.floats(-1e6, 1e6, allow_nan=False)
anything = st.floats(allow_nan=True, allow_infinity=True)


@settings(max_examples=150, deadline=None)
@given(
    position=st.tuples(finite, st.floats(-10, 500), finite),
    yaw=st.floats(-10, 10),
    pitch=st.floats(-1.6, 1.6),
    stick=st.tuples(anything, anything),
)
def test_any_input_keeps_the_origin_finite(position, yaw, pitch, stick):
    loco = _locomotion()
    aim = Pose.from_yaw_pitch(position, yaw, pitch)
    before = InputState()
    for state in (
        InputState(right=HandInput(stick=(0.0, 1.0), aim=aim)),
        InputState(right=HandInput(stick=stick, aim=aim)),
        InputState(right=HandInput(aim=aim)),
    ):
        loco.update(before, state, HEAD, 0.0, lambda hand: False)
        before = state
    assert np.all(np.isfinite(loco.origin.offset)) and math.isfinite(loco.origin.yaw)
