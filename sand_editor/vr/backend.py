"""What the frame loop needs of a backend (the headset's or the desktop preview's): session
states, predicted frames with each eye's pose and field of view, controller input, and one
framebuffer per eye."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from sand_editor.vr.actions import InputState
from sand_editor.vr.xrmath import Fov, Pose


@dataclass
class EyeView:
    pose: Pose  # in the tracking space
    fov: Fov


@dataclass
class Frame:
    """One frame as the backend predicts it: ``display_time_s`` (seconds, any origin)."""

    display_time_s: float
    should_render: bool
    eyes: list[EyeView]
    input: InputState = field(default_factory=InputState)
    input_ms: float = 0.0  # reading the controls: the viewer's own work, part of the overhead
    # The display's refresh period: the runtime's refresh rate where it says it, else its
    # predicted display period.
    display_period_s: float = 1 / 90


class Backend(Protocol):
    name: str  # "xr" or "desktop"
    runtime: str
    system: str
    views: list[dict]  # per eye: width, height, fov (four angles)
    swapchain_format: str
    floor_level: bool  # tracking space y = 0 is the floor (STAGE)
    reference_space: str  # STAGE or LOCAL
    exiting: bool

    def poll_events(self) -> list[str]: ...  # session states entered since the last call
    def wait_frame(self) -> Frame | None: ...  # None while the session is not running
    def eye_target(self, index: int): ...  # context manager → (framebuffer, viewport)
    def end_frame(self, frame: Frame, rendered: bool) -> None: ...
    def interaction_profiles(self) -> dict[str, str | None]: ...
    def request_exit(self) -> None: ...
