"""Where the user is in the desert and what stands around them: the tracking space placed on the
dune (``locomotion``), the workbench in front of them (brought along on request), and the
scene-side drawing of both for each eye.

The frame loop owns one ``Stage``; it feeds it each frame's eyes and input, and asks it for
the eyes' world poses, the hands' and what to draw over each eye.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sand_editor.vr.backend import EyeView, Frame
from sand_editor.vr.bench_meshes import controller_props
from sand_editor.vr.locomotion import Locomotion, TrackingOrigin
from sand_editor.vr.workbench import Workbench
from sand_editor.vr.xrmath import Pose

STANDING_EYE_HEIGHT_M = 1.6


class Stage:
    """The user's place (``locomotion``) and the ``workbench``, on ``renderer``'s terrain."""

    def __init__(self, ctx, renderer, floor_level: bool) -> None:
        self.ctx = ctx
        self.renderer = renderer
        self.floor_level = floor_level
        self.workbench: Workbench | None = None
        self._place_workbench((0.0, 0.0), 0.0)
        self.bench_moves = 0  # placing the first bench was no move
        self.locomotion = Locomotion(renderer.terrain, TrackingOrigin(), self.blocks)
        self.placed = False  # the tracking space is put on the dune at the first frame
        self.head: np.ndarray | None = None  # between the eyes, in the tracking space
        self.eyes: list[EyeView] = []  # the latest eyes, in the tracking space
        self.now_s: float | None = None

    # ---- each frame ----------------------------------------------------------------------------

    def track(self, frame: Frame) -> None:
        """Take the frame's eyes (the first frame with eyes places the tracking space)."""
        self.now_s = frame.display_time_s
        if not frame.eyes:
            return
        self.eyes = frame.eyes
        self.head = np.asarray(between(frame.eyes).position, dtype=np.float64)
        if not self.placed:
            ground = float(self.renderer.terrain.height(0.0, 0.0))
            lift = 0.0
            if not self.floor_level:  # a space whose origin is the head: lift it to standing
                lift = max(STANDING_EYE_HEIGHT_M - float(self.head[1]), 0.0)
            self.locomotion.origin = TrackingOrigin((0.0, ground + lift, 0.0))
            self.locomotion.floor_lift = lift
            self.placed = True

    def aim_hands(self, state) -> None:
        """What each hand points at on the panel."""
        for hand, hand_input in state.hands():
            self.workbench.aim(hand, self.world(hand_input.aim))

    def locomote(self, previous, state) -> list[str]:
        """Teleports and turns from the controls (after the panel has had its presses)."""
        if self.head is None:
            return []
        hovered = self.workbench.hovered.get
        return self.locomotion.update(
            previous, state, self.head, self.now_s, lambda hand: hovered(hand) is not None
        )

    def world(self, pose: Pose | None) -> Pose | None:
        return self.locomotion.origin.pose(pose)

    def world_eyes(self, eyes: list[EyeView]) -> list[EyeView]:
        return [replace(e, pose=self.world(e.pose)) for e in eyes]

    def rays(self, state) -> tuple[list, list]:
        """(every hand's aim pose, the rays to draw) in the world: the hand throwing the
        teleport arc draws no ray, the arc is its pointer."""
        aim = self.locomotion.aim
        hands = [(name, self.world(h.aim)) for name, h in state.hands()]
        rays = [pose for name, pose in hands if aim is None or name != aim.hand]
        return [pose for _, pose in hands], rays

    def props(self, hands):
        """The renderer's ``extra`` for one frame: the desk and the controllers' bodies."""

        # The controllers' bodies are built once per frame, for both eyes.
        bodies = [controller_props(pose) for pose in hands if pose is not None]
        moving = np.vstack(bodies) if bodies else None

        def draw(camera, sky, shadows):
            self.workbench.draw_props(self.ctx, camera, sky, moving, shadows)

        return draw

    def overlay(self, camera, viewport, state, preset_name: str, rays, comfort: bool) -> None:
        """Over an eye's finished image: panel, rays, the arc and, where ``comfort`` (the
        controls' switch) is on, the vignette."""
        self.workbench.draw(self.ctx, camera, viewport, state, preset_name, rays,
                            self.locomotion.aim)  # fmt: skip
        vignette = self.locomotion.vignette(self.now_s) if comfort else 0.0
        self.workbench.draw_vignette(self.ctx, viewport, vignette)

    # ---- jumps asked for -----------------------------------------------------------------------

    def move(self, to=None, turn_degrees: float | None = None, bring_bench: bool = False) -> None:
        """Teleport the head above ``to`` (x, z), turn it by ``turn_degrees`` and bring the
        workbench before it: what the controllers do, asked for by the link."""
        head = self._head()
        if to is not None:
            self.locomotion.teleport_to(head, to[0], to[1], self.now_s)
        if turn_degrees:
            self.locomotion.turn(head, np.radians(turn_degrees), self.now_s)
        if bring_bench:
            self.bring_bench()

    def bring_bench(self) -> None:
        """The workbench in front of the head, facing the way it looks."""
        origin = self.locomotion.origin
        stand = origin.point(self._head())
        yaw = origin.yaw
        if self.eyes:
            forward = origin.pose(self.eyes[0].pose).forward
            if np.hypot(forward[0], forward[2]) > 1e-3:
                yaw = float(np.arctan2(-forward[0], -forward[2]))
        self._place_workbench((stand[0], stand[2]), yaw)

    def _head(self) -> np.ndarray:
        """The head in the tracking space (its origin before the first frame with eyes)."""
        return self.head if self.head is not None else np.zeros(3)

    def blocks(self, point) -> bool:
        """Whether a teleport to ``point`` would land in the desk."""
        return self.workbench.contains(point)

    def _place_workbench(self, stand_xz, yaw: float) -> None:
        if self.workbench is not None:
            self.workbench.release()
            self.renderer.clear_objects()
            self.bench_moves += 1
        terrain = self.renderer.terrain
        self.workbench = Workbench(lambda x, z: float(terrain.height(x, z)), stand_xz, yaw)
        for mesh, origin in self.workbench.sand_objects():
            self.renderer.add_object(mesh, origin)
        # The desk and the tray's walls cast shadows on the sand, and on themselves.
        self.renderer.add_caster(self.workbench.layout.props()[:, :3], self.workbench.layout.origin)

    def report(self) -> dict:
        head = self.locomotion.origin.point(self.head) if self.head is not None else None
        return {
            "teleports": self.locomotion.teleports,
            "snap_turns": self.locomotion.turns,
            "bench_moves": self.bench_moves,
            "head_in_world": None if head is None else [round(float(v), 3) for v in head],
            "yaw_deg": round(float(np.degrees(self.locomotion.origin.yaw)), 2),
        }

    def release(self) -> None:
        self.workbench.release()


def between(eyes: list[EyeView]) -> Pose:
    """The head: midway between the eyes, facing as the first eye does."""
    position = np.mean([e.pose.position for e in eyes], axis=0)
    return Pose(tuple(float(v) for v in position), eyes[0].pose.orientation)
