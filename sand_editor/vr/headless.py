"""A headless backend: both eyes drawn into offscreen framebuffers of a given size, from a head
that stands still looking at the workbench and the dunes, driving the same frame loop as a
headset with no display, window or runtime (the GPU benchmark, and tests).

The session opens and closes through the same states as the desktop preview's; frames come as
fast as they are drawn, one frame period of display time apart; ``end_frame`` only counts them,
and ends the session when ``stop_after`` (if set) says so.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import contextmanager

import moderngl
import numpy as np

from sand_editor.vr._files import read_pixels
from sand_editor.vr.actions import InputState
from sand_editor.vr.backend import EyeView, Frame
from sand_editor.vr.desktop import (
    FOV_Y_DEG,
    FRAME_PERIOD_S,
    IPD_M,
    START_PITCH_RAD,
    START_POSITION,
    SimulatedSession,
)
from sand_editor.vr.xrmath import Fov, Pose


class HeadlessBackend(SimulatedSession):
    """``windows`` gives ``ctx`` (a ``glwindow.HeadlessContexts``, or any object the frame
    loop takes); each eye is an RGBA8 texture with a depth renderbuffer of ``size``.

    ``stop_after(frames_ended)``, asked after each frame, ends the session when it returns True
    (the frame loop's ``frames`` option ends it too).
    """

    name = "headless"
    floor_level = True
    reference_space = "STAGE"
    swapchain_format = "RGBA8 texture, 24-bit depth renderbuffer (sRGB-encoded bytes)"

    def __init__(self, windows, size: tuple[int, int]) -> None:
        self.windows = windows
        self.ctx: moderngl.Context = windows.ctx
        self.size = size
        self.fov = Fov.symmetric(math.radians(FOV_Y_DEG), size[0] / size[1])
        self.runtime = "headless"
        self.system = f"offscreen on {self.ctx.info.get('GL_RENDERER', 'OpenGL')}"
        self.views = [
            {"width": size[0], "height": size[1], "fov": self.fov.as_dict()} for _ in range(2)
        ]
        super().__init__()
        self.frames_ended = 0
        self.frames_rendered = 0
        self.stop_after: Callable[[int], bool] | None = None
        self._head = Pose.from_yaw_pitch(START_POSITION, 0.0, START_PITCH_RAD)
        self._targets = []
        try:
            for _ in range(2):
                color = self.ctx.texture(size, 4)
                depth = self.ctx.depth_renderbuffer(size)
                framebuffer = self.ctx.framebuffer([color], depth)
                self._targets.append((framebuffer, color, depth))
        except BaseException:
            self._release_targets()
            raise

    # ---- session -------------------------------------------------------------------------

    def interaction_profiles(self) -> dict[str, str | None]:
        return {"left": None, "right": None}

    # ---- frames --------------------------------------------------------------------------

    def wait_frame(self) -> Frame | None:
        if self._state != "FOCUSED":
            return None
        rotation = self._head.rotation()
        eyes = [
            EyeView(self._head.translated(rotation[:, 0] * side * IPD_M / 2), self.fov)
            for side in (-1.0, 1.0)
        ]
        return Frame(self.frames_ended * FRAME_PERIOD_S, True, eyes, InputState())

    @contextmanager
    def eye_target(self, index: int):
        yield self._targets[index][0], (0, 0, *self.size)

    def end_frame(self, frame: Frame, rendered: bool) -> None:
        self.frames_ended += 1
        self.frames_rendered += rendered
        if self.stop_after is not None and self.stop_after(self.frames_ended):
            self.request_exit()

    def eye_image(self, index: int) -> np.ndarray:
        """(height, width, 3) uint8 of what the eye last showed, rows top-down."""
        return read_pixels(self._targets[index][0], (0, 0, *self.size))

    def close(self) -> None:
        self._release_targets()
        self.windows.close()

    def _release_targets(self) -> None:
        for objects in self._targets:
            for gl_object in objects:
                gl_object.release()
        self._targets = []
