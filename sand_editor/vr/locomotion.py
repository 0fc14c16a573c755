"""Getting about the desert: where the tracking space sits in the world, teleporting along an
arc onto the dunes, snap turns, and the comfort vignette that covers each jump.

Pure maths and plain data, shared by the headset and the desktop preview: the frame loop feeds
``Locomotion.update`` each frame's input and the head's tracking pose, and draws what
``aim`` and ``vignette`` say.

Controls (``sand_editor.vr.actions`` reads them into ``InputState``):
- the right stick pushed forward aims the arc from the right hand; letting it go teleports
  there, the head landing on the arc's end;
- the right stick flicked left or right turns by ``SNAP_TURN_DEG`` about the head;
- a trigger held away from the panel aims the arc from that hand, as the stick does (the only
  way on controllers without a stick); released, it teleports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from sand_editor.vr.actions import TRIGGER_PRESS, InputState
from sand_editor.vr.xrmath import Pose, quaternion_product

SNAP_TURN_DEG = 30.0
STICK_ENGAGE = 0.7  # a stick past this aims (forward) or turns (sideways)
STICK_RELEASE = 0.3  # ... and must come back inside this before it acts again
TRIGGER_RELEASE = 0.35
LAUNCH_SPEED_M_S = 16.0  # the arc's reach: about 28 m over flat ground from a raised hand
GRAVITY_M_S2 = 9.81
ARC_STEP_S = 0.025
ARC_MAX_S = 5.0
MAX_SLOPE_DEG = 40.0  # steeper ground cannot be stood on: the arc shows it as refused
VIGNETTE_S = 0.35  # a jump's vignette closes at once and opens over this time


@dataclass(frozen=True)
class TrackingOrigin:
    """The tracking space placed in the world: turned by ``yaw`` (radians about +y, positive
    to the left) and then moved by ``offset`` (world metres, float64)."""

    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0

    def rotation(self) -> np.ndarray:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

    def point(self, tracking) -> np.ndarray:
        """A tracking-space point in the world."""
        return self.rotation() @ np.asarray(tracking, dtype=np.float64) + np.asarray(self.offset)

    def pose(self, pose: Pose | None) -> Pose | None:
        """A tracking-space pose in the world (None stays None)."""
        if pose is None:
            return None
        half = self.yaw / 2
        turn = (0.0, math.sin(half), 0.0, math.cos(half))
        position = tuple(float(v) for v in self.point(pose.position))
        return Pose(position, quaternion_product(turn, pose.orientation))

    def teleported(self, head_tracking, target, floor_lift: float = 0.0) -> TrackingOrigin:
        """The origin that puts the head (tracking position) above ``target`` on the ground,
        its height above the floor as it was (``floor_lift`` added for a space without one)."""
        head = self.rotation() @ np.asarray(head_tracking, dtype=np.float64)
        target = np.asarray(target, dtype=np.float64)
        offset = (target[0] - head[0], target[1] + floor_lift, target[2] - head[2])
        return replace(self, offset=tuple(float(v) for v in offset))

    def turned(self, head_tracking, angle_rad: float) -> TrackingOrigin:
        """Turned by ``angle_rad`` about the vertical through the head, which stays put."""
        head_world = self.point(head_tracking)
        turned = replace(self, yaw=_wrap(self.yaw + angle_rad))
        moved = turned.point(head_tracking)
        offset = np.asarray(self.offset) + head_world - moved
        return replace(turned, offset=tuple(float(v) for v in offset))


@dataclass(frozen=True)
class Aim:
    """A teleport being aimed: the arc's points (world), where it lands and whether the ground
    there can be stood on."""

    hand: str
    points: np.ndarray  # (n, 3)
    target: np.ndarray | None
    valid: bool


def teleport_arc(start, direction, height_at) -> tuple[np.ndarray, np.ndarray | None]:
    """The arc thrown from ``start`` along ``direction`` (a ballistic path), up to where it
    meets the ground ``height_at(x, z)``; returns (points, landing point or None)."""
    start = np.asarray(start, dtype=np.float64)
    direction = np.asarray(direction, dtype=np.float64)
    norm = float(np.linalg.norm(direction))
    if not (norm > 1e-9 and math.isfinite(norm) and np.all(np.isfinite(start))):
        return start[None, :], None
    velocity = direction / norm * LAUNCH_SPEED_M_S
    t = np.arange(int(ARC_MAX_S / ARC_STEP_S) + 1)[:, None] * ARC_STEP_S
    points = start + velocity * t
    points[:, 1] -= 0.5 * GRAVITY_M_S2 * t[:, 0] ** 2
    # One vectorised height query for the whole arc, then the crossing refined.
    below = np.flatnonzero(points[:, 1] <= height_at(points[:, 0], points[:, 2]))
    if len(below) == 0:
        return points, None
    first = int(below[0])
    if first == 0:
        return points[:1], None  # the hand is under the ground: nowhere to throw
    landing = _bisect(points[first - 1], points[first], height_at)
    return np.vstack([points[:first], landing]), landing


def _bisect(above, below, height_at, steps: int = 12) -> np.ndarray:
    """Where the segment from a point ``above`` the ground to one ``below`` it crosses it."""
    for _ in range(steps):
        middle = (above + below) / 2
        if middle[1] > float(height_at(middle[0], middle[2])):
            above = middle
        else:
            below = middle
    point = (above + below) / 2
    return np.array([point[0], float(height_at(point[0], point[2])), point[2]])


class Locomotion:
    """The user's place in the world and the jumps that change it.

    ``origin`` is where the tracking space sits; ``aim`` the teleport being aimed (None when
    none); ``teleports`` and ``turns`` count the jumps; ``vignette`` is how far a jump closes
    the comfort vignette (the viewer's controls say whether it is drawn).
    ``teleport_to`` and ``turn`` make the same jumps as the controls, for the link."""

    def __init__(self, terrain, origin: TrackingOrigin, blocked=None) -> None:
        self.terrain = terrain
        self.blocked = blocked  # blocked(point): no landing there (the desk)
        self.origin = origin
        self.floor_lift = 0.0  # for a space whose origin is the head: the standing height
        self.aim: Aim | None = None
        self.teleports = 0
        self.turns = 0
        self.last_jump_s: float | None = None
        self._aiming_hand: str | None = None
        self._aiming_by: str | None = None  # "stick" or "trigger"
        self._turn_armed = True

    def update(self, previous: InputState, state: InputState, head_tracking, now_s: float,
               panel_hovered) -> list[str]:  # fmt: skip
        """Apply one frame's input; returns the jumps made ("teleport", "turn")."""
        jumps = []
        right = state.right
        x, y = (_finite(v) for v in right.stick)
        if self._turn_armed and abs(x) >= STICK_ENGAGE and self._aiming_hand is None:
            self.turn(head_tracking, math.radians(SNAP_TURN_DEG) * (-1.0 if x > 0 else 1.0), now_s)
            self._turn_armed = False
            jumps.append("turn")
        elif abs(x) <= STICK_RELEASE:
            self._turn_armed = True
        if self._aiming_hand is None:
            if y >= STICK_ENGAGE:
                self._aiming_hand, self._aiming_by = "right", "stick"
            else:
                for (hand, now), (_, before) in zip(state.hands(), previous.hands(), strict=True):
                    pulled = now.select >= TRIGGER_PRESS > before.select
                    if pulled and not panel_hovered(hand):
                        self._aiming_hand, self._aiming_by = hand, "trigger"
                        break
        if self._aiming_hand is not None:
            hand_input = dict(state.hands())[self._aiming_hand]
            if self._aiming_by == "stick":
                released = y <= STICK_RELEASE
            else:
                released = hand_input.select <= TRIGGER_RELEASE
            if released:
                if self.aim is not None and self.aim.valid:
                    self._teleport(head_tracking, self.aim.target, now_s)
                    jumps.append("teleport")
                self.aim = None
                self._aiming_hand = self._aiming_by = None
            else:
                self.aim = self._aim(self._aiming_hand, self.origin.pose(hand_input.aim))
        return jumps

    def teleport_to(self, head_tracking, x: float, z: float, now_s: float | None) -> None:
        self._teleport(head_tracking, (x, float(self.terrain.height(x, z)), z), now_s)

    def _teleport(self, head_tracking, target, now_s: float | None) -> None:
        self.origin = self.origin.teleported(head_tracking, target, self.floor_lift)
        self.teleports += 1
        self.last_jump_s = now_s

    def turn(self, head_tracking, angle_rad: float, now_s: float | None) -> None:
        self.origin = self.origin.turned(head_tracking, angle_rad)
        self.turns += 1
        self.last_jump_s = now_s

    def _aim(self, hand: str, pose: Pose | None) -> Aim | None:
        if pose is None:
            return None
        points, target = teleport_arc(pose.position, pose.forward, self.terrain.height)
        valid = target is not None and self._standable(target)
        valid = valid and not (self.blocked is not None and self.blocked(target))
        return Aim(hand, points, target, valid)

    def _standable(self, point) -> bool:
        gx, gz = (float(g) for g in self.terrain.gradient(point[0], point[2]))
        return math.hypot(gx, gz) <= math.tan(math.radians(MAX_SLOPE_DEG))

    def vignette(self, now_s: float) -> float:
        """How far the comfort vignette is closed, 0 (open) to 1, ``now_s`` after a jump."""
        if self.last_jump_s is None:
            return 0.0
        elapsed = now_s - self.last_jump_s
        if not (0.0 <= elapsed < VIGNETTE_S):
            return 0.0
        return 1.0 - elapsed / VIGNETTE_S


def _finite(value: float) -> float:
    return float(value) if math.isfinite(value) else 0.0


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi
