"""The controllers, read each frame: the states of the viewer's OpenXR actions (``ACTIONS``, made
and bound by ``xr_backend``) and the aim poses of both hands, as an ``InputState``."""

from __future__ import annotations

from contextlib import ExitStack

import xr

from sand_editor.vr.actions import Button, HandInput, InputState
from sand_editor.vr.xrmath import Pose


class ControllerInput:
    """The actions of ``action_set`` (attached to ``session``) per hand of ``hand_paths``, with
    aim poses located in ``space``; the aim spaces it creates are released by ``teardown``."""

    def __init__(
        self, session, space, action_set, actions: dict, hand_paths: dict, teardown: ExitStack
    ) -> None:
        self._session = session
        self._space = space
        self._action_set = action_set
        self._actions = actions
        self._hand_paths = hand_paths
        self._aim_spaces = {}
        for hand, path in hand_paths.items():
            aim = xr.create_action_space(
                session, xr.ActionSpaceCreateInfo(action=actions["aim"], subaction_path=path)
            )
            self._aim_spaces[hand] = aim
            teardown.callback(xr.destroy_space, aim)

    def read(self, display_time) -> InputState:
        """Both hands' controls now, aims at ``display_time``; none while the runtime gives the
        session no input (``SessionNotFocused``)."""
        try:
            xr.sync_actions(
                self._session,
                xr.ActionsSyncInfo(active_action_sets=[xr.ActiveActionSet(self._action_set, 0)]),
            )
        except xr.SessionNotFocused:
            return InputState()
        actions = self._actions
        hands = {}
        for hand, path in self._hand_paths.items():
            hands[hand] = HandInput(
                stick=self._vector(actions["scrub" if hand == "left" else "locomote"], path),
                select=self._float(actions["select"], path),
                **{button: self._boolean(actions[button], path) for button in Button},
                aim=self._aim(hand, display_time),
            )
        return InputState(**hands)

    def _info(self, action, path):
        return xr.ActionStateGetInfo(action=action, subaction_path=path)

    def _vector(self, action, path) -> tuple[float, float]:
        state = xr.get_action_state_vector2f(self._session, self._info(action, path))
        return (state.current_state.x, state.current_state.y) if state.is_active else (0.0, 0.0)

    def _float(self, action, path) -> float:
        state = xr.get_action_state_float(self._session, self._info(action, path))
        return float(state.current_state) if state.is_active else 0.0

    def _boolean(self, action, path) -> bool:
        state = xr.get_action_state_boolean(self._session, self._info(action, path))
        return bool(state.current_state) if state.is_active else False

    def _aim(self, hand: str, display_time) -> Pose | None:
        location = xr.locate_space(self._aim_spaces[hand], self._space, display_time)
        flags = location.location_flags
        wanted = (
            xr.SpaceLocationFlags.POSITION_VALID_BIT | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT
        )
        if (flags & wanted) != wanted:
            return None
        return as_pose(location.pose)


def as_pose(pose) -> Pose:
    """A pyopenxr ``Posef`` as a ``Pose``."""
    p, q = pose.position, pose.orientation
    return Pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
