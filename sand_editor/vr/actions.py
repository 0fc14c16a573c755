"""What the viewer's controls do: controller (or keyboard) input → commands → viewer state.

Pure functions and plain data: the OpenXR backend fills ``InputState`` from its actions, the
desktop backend from the keyboard and mouse, and both go through ``commands_from_input``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import StrEnum

from sand_editor.view import MAX_DAY_SPEED, ViewState, wrap_hours
from sand_editor.vr.xrmath import Pose

STICK_DEAD_ZONE = 0.2
SCRUB_HOURS_PER_S = 3.0  # full stick deflection
SPEED_CHANGE_PER_S = 2.0  # hours per second, per second, at full deflection
TRIGGER_PRESS = 0.75
# Panel steps of the day speed, simulated hours per real second (0 = paused clock).
SPEED_STEPS = (0.0, 1 / 60, 0.1, 0.25, 0.5, 1.0, 2.0, 6.0, 24.0)
COMPARISON_MODE = "lambert"

HANDS = ("left", "right")


class CommandKind(StrEnum):
    """What a command does (see ``Command``)."""

    SCRUB = "scrub"
    SPEED = "speed"
    SPEED_STEP = "speed_step"
    PLAY_PAUSE = "play_pause"
    NEXT_PRESET = "next_preset"
    TOGGLE_LAMBERT = "toggle_lambert"
    TOGGLE_COMFORT = "toggle_comfort"
    BRING_BENCH = "bring_bench"
    PRESS = "press"


class Button(StrEnum):
    """A controller's buttons: each is an OpenXR boolean action of its name, a ``HandInput``
    field, and on its press the command of the same name."""

    PLAY_PAUSE = "play_pause"
    NEXT_PRESET = "next_preset"
    TOGGLE_LAMBERT = "toggle_lambert"
    BRING_BENCH = "bring_bench"

    @property
    def command(self) -> CommandKind:
        return CommandKind(self.value)


# OpenXR actions: name → (type, localized name). Types: "boolean", "float", "vector2f", "pose".
ACTIONS = {
    "scrub": ("vector2f", "Scrub time and day speed"),
    "locomote": ("vector2f", "Teleport and turn"),
    "select": ("float", "Press a panel button"),
    Button.PLAY_PAUSE: ("boolean", "Play or pause the day"),
    Button.NEXT_PRESET: ("boolean", "Next sand"),
    Button.TOGGLE_LAMBERT: ("boolean", "Compare with Lambert"),
    Button.BRING_BENCH: ("boolean", "Bring the workbench"),
    "aim": ("pose", "Aim"),
}

# Suggested bindings per interaction profile: (action, component under /user/hand/<hand>/).
# Each path must exist in the profile for that hand: one unknown path rejects the whole profile.
_BOTH = HANDS
BINDINGS: dict[str, list[tuple[str, tuple[str, ...], str]]] = {
    "/interaction_profiles/khr/simple_controller": [
        ("select", _BOTH, "input/select/click"),
        ("play_pause", ("right",), "input/menu/click"),
        ("bring_bench", ("left",), "input/menu/click"),
        ("aim", _BOTH, "input/aim/pose"),
    ],
    "/interaction_profiles/oculus/touch_controller": [
        ("scrub", ("left",), "input/thumbstick"),
        ("locomote", ("right",), "input/thumbstick"),
        ("select", _BOTH, "input/trigger/value"),
        ("play_pause", ("left",), "input/x/click"),
        ("play_pause", ("right",), "input/a/click"),
        ("next_preset", ("left",), "input/y/click"),
        ("next_preset", ("right",), "input/b/click"),
        ("bring_bench", ("left",), "input/thumbstick/click"),
        ("toggle_lambert", ("right",), "input/thumbstick/click"),
        ("aim", _BOTH, "input/aim/pose"),
    ],
    "/interaction_profiles/valve/index_controller": [
        ("scrub", ("left",), "input/thumbstick"),
        ("locomote", ("right",), "input/thumbstick"),
        ("select", _BOTH, "input/trigger/value"),
        ("play_pause", _BOTH, "input/a/click"),
        ("next_preset", _BOTH, "input/b/click"),
        ("bring_bench", ("left",), "input/thumbstick/click"),
        ("toggle_lambert", ("right",), "input/thumbstick/click"),
        ("aim", _BOTH, "input/aim/pose"),
    ],
    "/interaction_profiles/microsoft/motion_controller": [
        ("scrub", ("left",), "input/thumbstick"),
        ("locomote", ("right",), "input/thumbstick"),
        ("select", _BOTH, "input/trigger/value"),
        ("play_pause", _BOTH, "input/menu/click"),
        ("next_preset", _BOTH, "input/squeeze/click"),
        ("bring_bench", ("left",), "input/trackpad/click"),
        ("toggle_lambert", ("right",), "input/trackpad/click"),
        ("aim", _BOTH, "input/aim/pose"),
    ],
}


def binding_paths(profile: str) -> list[tuple[str, str]]:
    """(action, full input path) pairs suggested for ``profile``."""
    return [
        (action, f"/user/hand/{hand}/{component}")
        for action, hands, component in BINDINGS[profile]
        for hand in hands
    ]


@dataclass(frozen=True)
class HandInput:
    """One hand's controls at one moment; ``aim`` is None while not tracked; a field per
    ``Button``."""

    stick: tuple[float, float] = (0.0, 0.0)  # the left's scrubs the time, the right's locomotes
    select: float = 0.0
    play_pause: bool = False
    next_preset: bool = False
    toggle_lambert: bool = False
    bring_bench: bool = False
    aim: Pose | None = None


@dataclass(frozen=True)
class InputState:
    left: HandInput = field(default_factory=HandInput)
    right: HandInput = field(default_factory=HandInput)

    def hands(self):
        return (("left", self.left), ("right", self.right))


def buttons_down(hand: HandInput) -> frozenset[Button]:
    return frozenset(button for button in Button if getattr(hand, button))


@dataclass(frozen=True)
class Command:
    """``kind`` (a ``CommandKind``, or its value): ``scrub`` (``value`` hours), ``speed``
    (``value`` hours/s added), ``speed_step`` (±1 along SPEED_STEPS), ``play_pause``,
    ``next_preset``, ``toggle_lambert``, ``toggle_comfort``, ``bring_bench``, ``press`` (trigger
    pulled; ``hand`` aims at something). An unknown kind raises ``ValueError``."""

    kind: CommandKind
    value: float = 0.0
    hand: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", CommandKind(self.kind))


def _dead_zone(value: float) -> float:
    if not math.isfinite(value) or abs(value) <= STICK_DEAD_ZONE:
        return 0.0
    # Rescaled so the response starts at 0 just outside the dead zone.
    sign = 1.0 if value > 0 else -1.0
    return sign * min((abs(value) - STICK_DEAD_ZONE) / (1.0 - STICK_DEAD_ZONE), 1.0)


def commands_from_input(previous: InputState, current: InputState, dt_s: float) -> list[Command]:
    """Commands for the change from ``previous`` to ``current`` over ``dt_s`` seconds: the left
    stick acts continuously (x scrubs the time, y changes the day speed; the right stick is
    ``locomotion``'s), buttons and the trigger on their press only."""
    dt_s = dt_s if math.isfinite(dt_s) and dt_s > 0 else 0.0
    commands = []
    scrub = _dead_zone(current.left.stick[0]) * SCRUB_HOURS_PER_S * dt_s
    speed = _dead_zone(current.left.stick[1]) * SPEED_CHANGE_PER_S * dt_s
    for (hand, now), (_, before) in zip(current.hands(), previous.hands(), strict=True):
        pressed = buttons_down(now) - buttons_down(before)
        commands += [Command(button.command, hand=hand) for button in Button if button in pressed]
        if now.select >= TRIGGER_PRESS and before.select < TRIGGER_PRESS:
            commands.append(Command(CommandKind.PRESS, hand=hand))
    if scrub:
        commands.insert(0, Command(CommandKind.SCRUB, scrub))
    if speed:
        commands.insert(0, Command(CommandKind.SPEED, speed))
    return commands


@dataclass(frozen=True)
class ViewerControls:
    """What the user controls besides the view (``sand_editor.view.ViewState``: the clock and
    the mode): the sand shown and the mode the Lambert comparison returns to.

    ``preset_count`` names are on the panel; ``preset_index`` picks one.
    """

    preset_index: int = 0
    preset_count: int = 1
    previous_mode: str = "full"
    comfort: bool = True  # the vignette over teleports and turns: its only switch


def apply_command(
    controls: ViewerControls, view: ViewState, command: Command
) -> tuple[ViewerControls, dict]:
    """The controls after ``command``, and the changes it makes to the view (``ViewState``
    fields, for ``ViewModel.update``); ``press`` and ``bring_bench`` change neither."""
    match command.kind:
        case CommandKind.SCRUB:
            return controls, {"hours": wrap_hours(view.hours + command.value)}
        case CommandKind.SPEED:
            speed = min(max(view.day_speed + command.value, 0.0), MAX_DAY_SPEED)
            return controls, {"day_speed": speed}
        case CommandKind.SPEED_STEP:
            return controls, {"day_speed": _step_speed(view.day_speed, int(command.value))}
        case CommandKind.PLAY_PAUSE:
            playing = not view.playing
            # Playing a day whose speed is 0 would look broken: start it at real-time-ish speed.
            speed = view.day_speed if view.day_speed > 0 or not playing else SPEED_STEPS[3]
            return controls, {"playing": playing, "day_speed": speed}
        case CommandKind.NEXT_PRESET:
            count = max(controls.preset_count, 1)
            return replace(controls, preset_index=(controls.preset_index + 1) % count), {}
        case CommandKind.TOGGLE_LAMBERT:
            if view.mode == COMPARISON_MODE:
                back = controls.previous_mode
                return controls, {"mode": back if back != COMPARISON_MODE else "full"}
            return replace(controls, previous_mode=view.mode), {"mode": COMPARISON_MODE}
        case CommandKind.TOGGLE_COMFORT:
            return replace(controls, comfort=not controls.comfort), {}
        case CommandKind.PRESS | CommandKind.BRING_BENCH:
            return controls, {}  # the workbench's and the stage's (``FrameLoop.run_command``)


def _step_speed(speed: float, steps: int) -> float:
    nearest = min(range(len(SPEED_STEPS)), key=lambda i: abs(SPEED_STEPS[i] - speed))
    return SPEED_STEPS[min(max(nearest + steps, 0), len(SPEED_STEPS) - 1)]
