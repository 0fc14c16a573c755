"""Controller input → commands → viewer state, and the suggested bindings."""

from __future__ import annotations

import re

import pytest

from sand_editor.view import MAX_DAY_SPEED, ViewModel, ViewState
from sand_editor.vr.actions import (
    ACTIONS,
    BINDINGS,
    SCRUB_HOURS_PER_S,
    SPEED_STEPS,
    Button,
    Command,
    CommandKind,
    HandInput,
    InputState,
    ViewerControls,
    apply_command,
    binding_paths,
    commands_from_input,
)

# Inputs each profile has, per the OpenXR specification's interaction profile lists.
PROFILE_INPUTS = {
    "khr/simple_controller": {"select/click", "menu/click", "grip/pose", "aim/pose"},
    "oculus/touch_controller": {
        "left": {"x/click", "y/click", "menu/click"},
        "right": {"a/click", "b/click"},
        "both": {
            "squeeze/value",
            "trigger/value",
            "trigger/touch",
            "thumbstick",
            "thumbstick/x",
            "thumbstick/y",
            "thumbstick/click",
            "grip/pose",
            "aim/pose",
        },
    },  # fmt: skip
    "valve/index_controller": {
        "a/click",
        "b/click",
        "trigger/value",
        "trigger/click",
        "thumbstick",
        "thumbstick/click",
        "trackpad",
        "aim/pose",
        "grip/pose",
        "squeeze/value",
        "system/click",
    },  # fmt: skip
    "microsoft/motion_controller": {
        "menu/click",
        "squeeze/click",
        "trigger/value",
        "thumbstick",
        "thumbstick/click",
        "trackpad",
        "trackpad/click",
        "aim/pose",
        "grip/pose",
    },  # fmt: skip
}


def _allowed(profile: str, hand: str) -> set[str]:
    inputs = PROFILE_INPUTS[profile]
    if isinstance(inputs, dict):
        return inputs[hand] | inputs["both"]
    return inputs


@pytest.mark.parametrize("profile", sorted(BINDINGS))
def test_every_suggested_path_exists_in_its_profile(profile):
    short = profile.removeprefix("/interaction_profiles/")
    paths = binding_paths(profile)
    assert paths
    for action, path in paths:
        assert action in ACTIONS
        hand, component = re.fullmatch(r"/user/hand/(left|right)/input/(.+)", path).groups()
        assert component in _allowed(short, hand), f"{path} is not in {short}"


@pytest.mark.parametrize("profile", sorted(BINDINGS))
def test_every_profile_binds_both_aims_and_a_trigger(profile):
    paths = binding_paths(profile)
    for hand in ("left", "right"):
        assert ("aim", f"/user/hand/{hand}/input/aim/pose") in paths
        assert any(a == "select" and f"/{hand}/" in p for a, p in paths)


def test_stick_scrubs_the_time_proportionally_and_respects_the_dead_zone():
    rest = InputState()
    full = InputState(left=HandInput(stick=(1.0, 0.0)))
    (scrub,) = commands_from_input(rest, full, 0.5)
    # The right stick is locomotion's: it does not scrub.
    assert commands_from_input(rest, InputState(right=HandInput(stick=(1.0, 1.0))), 0.5) == []
    assert scrub.kind == "scrub" and scrub.value == pytest.approx(SCRUB_HOURS_PER_S * 0.5)
    assert commands_from_input(rest, InputState(left=HandInput(stick=(0.15, -0.1))), 0.5) == []
    (back,) = commands_from_input(rest, InputState(left=HandInput(stick=(-0.6, 0.0))), 1.0)
    assert back.value == pytest.approx(-0.5 * SCRUB_HOURS_PER_S)


def test_non_finite_input_and_time_step_do_nothing():
    broken = InputState(left=HandInput(stick=(float("nan"), float("inf"))))
    assert commands_from_input(InputState(), broken, 0.1) == []
    full = InputState(left=HandInput(stick=(1.0, 0.0)))
    assert commands_from_input(InputState(), full, float("nan")) == []


def test_buttons_and_trigger_act_on_the_press_only():
    up = InputState()
    down = InputState(
        left=HandInput(play_pause=True, select=0.9), right=HandInput(toggle_lambert=True)
    )
    kinds = [(c.kind, c.hand) for c in commands_from_input(up, down, 0.01)]
    assert ("play_pause", "left") in kinds
    assert ("toggle_lambert", "right") in kinds
    assert ("press", "left") in kinds
    assert commands_from_input(down, down, 0.01) == []


def test_each_button_is_an_action_a_hand_field_and_a_command():
    for button in Button:
        assert ACTIONS[button][0] == "boolean"
        pressed = InputState(right=HandInput(**{button: True}))
        (command,) = commands_from_input(InputState(), pressed, 0.01)
        assert command.kind is button.command and command.hand == "right"
    actions = {name for name, (kind, _) in ACTIONS.items() if kind == "boolean"}
    assert actions == set(Button)


def test_commands_are_of_a_known_kind():
    assert Command("scrub", 1.0).kind is CommandKind.SCRUB
    with pytest.raises(ValueError, match="toggle_sun"):
        Command("toggle_sun")


def test_the_vignette_switch_is_the_controls_own():
    controls = ViewerControls()
    off, changes = apply_command(controls, ViewState(), Command(CommandKind.TOGGLE_COMFORT))
    assert (controls.comfort, off.comfort, changes) == (True, False, {})
    assert apply_command(off, ViewState(), Command(CommandKind.TOGGLE_COMFORT))[0].comfort


def _apply(view: ViewState, kind: str, value: float = 0.0, controls=None):
    """The view after a command, through the view model as the frame loop applies it."""
    model = ViewModel(view)
    _controls, changes = apply_command(controls or ViewerControls(), view, Command(kind, value))
    model.update("input", **changes)
    return model.state


def test_scrub_wraps_the_clock_and_speed_stays_in_range():
    view = ViewState(hours=23.5)
    assert _apply(view, "scrub", 1.0).hours == pytest.approx(0.5)
    assert _apply(view, "scrub", -24.0).hours == pytest.approx(23.5)
    fast = _apply(view, "speed", 1e9)
    assert fast.day_speed == MAX_DAY_SPEED
    assert _apply(fast, "speed", -1e9).day_speed == 0.0
    stepped = _apply(ViewState(day_speed=0.5), "speed_step", 1)
    assert stepped.day_speed == SPEED_STEPS[SPEED_STEPS.index(0.5) + 1]
    assert _apply(ViewState(day_speed=24.0), "speed_step", 1).day_speed == 24


def test_play_starts_a_stopped_clock_and_the_day_advances():
    playing = _apply(ViewState(hours=12.0, day_speed=0.0), "play_pause")
    assert playing.playing and playing.day_speed > 0
    model = ViewModel(playing)
    model.tick(2.0)
    later = model.state
    assert later.hours == pytest.approx(12.0 + 2.0 * playing.day_speed)
    paused = _apply(later, "play_pause")
    model = ViewModel(paused)
    assert model.tick(10.0) == frozenset() and model.state.hours == later.hours
    assert paused.day_speed == playing.day_speed  # kept while paused


def test_lambert_toggle_returns_to_the_mode_before():
    glints = ViewState(mode="glints")
    controls, changes = apply_command(ViewerControls(), glints, Command("toggle_lambert"))
    assert changes == {"mode": "lambert"} and controls.previous_mode == "glints"
    compared = ViewState(mode="lambert")
    assert apply_command(controls, compared, Command("toggle_lambert"))[1] == {"mode": "glints"}


def test_next_preset_cycles():
    controls = ViewerControls(preset_index=2, preset_count=3)
    after, changes = apply_command(controls, ViewState(), Command("next_preset"))
    assert after.preset_index == 0 and changes == {}
