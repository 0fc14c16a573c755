"""The desktop stereo preview: both eyes side by side in a window, the head moved with the
mouse and keyboard, driving the same frame loop as a headset.

Keys: arrows ←/→ scrub the time, ↑/↓ change the day speed (the left stick), Space play/pause,
N next sand, L Lambert comparison, W/A/S/D walk, Q/E crouch and rise, Z/C snap turn left and
right and T (held) aims a teleport (the right stick), B brings the workbench, Esc quit. Drag
with the right mouse button to look around; the left button is the trigger of a ray from just
below the eyes: on the panel it presses, elsewhere it aims a teleport while held.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager

from sand_editor.vr.actions import HandInput, InputState
from sand_editor.vr.backend import EyeView, Frame
from sand_editor.vr.xrmath import Fov, Pose

EYE_SIZE = (480, 360)
IPD_M = 0.063
FOV_Y_DEG = 80.0
WALK_M_PER_S = 1.2
LOOK_RAD_PER_PIXEL = 0.004
START_POSITION = (0.0, 1.6, 0.0)
START_PITCH_RAD = math.radians(-38.0)  # looking down at the workbench
FRAME_PERIOD_S = 1 / 90

_OPENING = ("IDLE", "READY", "SYNCHRONIZED", "VISIBLE", "FOCUSED")
_CLOSING = ("VISIBLE", "SYNCHRONIZED", "STOPPING", "IDLE", "EXITING")


def eye_size(render_scale: float) -> tuple[int, int]:
    return (max(16, round(EYE_SIZE[0] * render_scale)), max(16, round(EYE_SIZE[1] * render_scale)))


class SimulatedSession:
    """A session that opens and closes through OpenXR's states with no runtime: the desktop
    preview's and the headless backend's."""

    def __init__(self) -> None:
        self.exiting = False
        self._states = list(_OPENING)
        self._state = None

    def poll_events(self) -> list[str]:
        entered, self._states = self._states, []
        if entered:
            self._state = entered[-1]
        if self._state == "EXITING":
            self.exiting = True
        return entered

    def request_exit(self) -> None:
        if self._state == "FOCUSED" and not self._states:
            self._states = list(_CLOSING)
        elif self._state is None:  # asked before the session began: nothing to stop
            self._states = ["EXITING"]


class DesktopBackend(SimulatedSession):
    """``windows`` is a visible ``GLWindows`` two eyes wide.

    The eyes are drawn side by side into a framebuffer of the viewer's own, the window's size,
    and copied to the window at the end of each frame. They are never drawn into or read from
    the window's framebuffer: moderngl reads any framebuffer by selecting its colour attachment
    0 (``glReadBuffer``), which the window's default framebuffer does not have, so a screenshot
    of ``ctx.screen`` left GL_INVALID_OPERATION pending for whatever GL call came next.
    """

    name = "desktop"
    floor_level = True
    reference_space = "STAGE"  # the floor is y = 0, as in a headset's STAGE space
    swapchain_format = "RGBA8 texture, 24-bit depth renderbuffer, copied to the window"

    def __init__(self, windows, size: tuple[int, int]) -> None:
        self.windows = windows
        self.glfw = windows.glfw
        self.ctx = windows.ctx
        self.size = size
        fov = Fov.symmetric(math.radians(FOV_Y_DEG), size[0] / size[1])
        self.fov = fov
        self.runtime = "desktop preview"
        self.system = f"window on {self.ctx.info.get('GL_RENDERER', 'OpenGL')}"
        self.views = [{"width": size[0], "height": size[1], "fov": fov.as_dict()} for _ in range(2)]
        super().__init__()
        self._position = list(START_POSITION)
        self._yaw = 0.0
        self._pitch = START_PITCH_RAD
        self._cursor = None
        self._last = time.perf_counter()
        self._next_frame = self._last
        both = (2 * size[0], size[1])
        self._colour = self.ctx.texture(both, 4)
        self._depth = self.ctx.depth_renderbuffer(both)
        self._eyes = self.ctx.framebuffer([self._colour], self._depth)
        # The colour alone for the copy: a blit of depth too would need the window's depth
        # format, which is the driver's choice.
        self._shown = self.ctx.framebuffer([self._colour])

    # ---- session -------------------------------------------------------------------------

    def poll_events(self) -> list[str]:
        self.glfw.poll_events()
        if self.glfw.window_should_close(self.windows.window) or self._pressed("ESCAPE"):
            self.request_exit()
        return super().poll_events()

    def interaction_profiles(self) -> dict[str, str | None]:
        return {"left": None, "right": "keyboard and mouse"}

    # ---- frames --------------------------------------------------------------------------

    def wait_frame(self) -> Frame | None:
        if self._state != "FOCUSED":
            return None
        now = time.perf_counter()
        if now < self._next_frame:
            time.sleep(self._next_frame - now)
            now = time.perf_counter()
        self._next_frame = max(now, self._next_frame) + FRAME_PERIOD_S
        dt = min(now - self._last, 0.25)
        self._last = now
        self._move(dt)
        head = Pose.from_yaw_pitch(self._position, self._yaw, self._pitch)
        rotation = head.rotation()
        eyes = [
            EyeView(head.translated(rotation[:, 0] * side * IPD_M / 2), self.fov)
            for side in (-1.0, 1.0)
        ]
        start = time.perf_counter()
        controls = self._input(head)
        return Frame(now, True, eyes, controls, (time.perf_counter() - start) * 1e3)

    @contextmanager
    def eye_target(self, index: int):
        width, height = self.size
        yield self._eyes, (index * width, 0, width, height)

    def end_frame(self, frame: Frame, rendered: bool) -> None:
        self.ctx.copy_framebuffer(self.ctx.screen, self._shown)
        self.glfw.swap_buffers(self.windows.window)

    def close(self) -> None:
        for gl_object in (self._shown, self._eyes, self._depth, self._colour):
            gl_object.release()
        self.windows.close()

    # ---- keyboard and mouse ----------------------------------------------------------------

    def _pressed(self, key: str) -> bool:
        glfw = self.glfw
        return glfw.get_key(self.windows.window, getattr(glfw, f"KEY_{key}")) == glfw.PRESS

    def _axis(self, negative: str, positive: str) -> float:
        return float(self._pressed(positive)) - float(self._pressed(negative))

    def _move(self, dt: float) -> None:
        glfw, window = self.glfw, self.windows.window
        cursor = glfw.get_cursor_pos(window)
        if (
            self._cursor is not None
            and glfw.get_mouse_button(window, glfw.MOUSE_BUTTON_RIGHT) == glfw.PRESS
        ):
            self._yaw -= (cursor[0] - self._cursor[0]) * LOOK_RAD_PER_PIXEL
            self._pitch -= (cursor[1] - self._cursor[1]) * LOOK_RAD_PER_PIXEL
            self._pitch = min(max(self._pitch, -1.55), 1.55)
        self._cursor = cursor
        forward = self._axis("S", "W") * WALK_M_PER_S * dt
        side = self._axis("A", "D") * WALK_M_PER_S * dt
        self._position[0] += -math.sin(self._yaw) * forward + math.cos(self._yaw) * side
        self._position[2] += -math.cos(self._yaw) * forward - math.sin(self._yaw) * side
        self._position[1] = min(max(self._position[1] + self._axis("Q", "E") * dt, 0.05), 3.0)

    def _input(self, head: Pose) -> InputState:
        glfw, window = self.glfw, self.windows.window
        rotation = head.rotation()
        # The ray leaves from a hand just below and right of the eyes, aimed where they look.
        hand = head.translated(rotation @ (0.12, -0.2, 0.0))
        target = head.position + head.forward * 1.0
        aim = _looking_from(hand.position, target)
        left = HandInput(
            stick=(self._axis("LEFT", "RIGHT"), self._axis("DOWN", "UP")),
            bring_bench=self._pressed("B"),
        )
        right = HandInput(
            stick=(self._axis("Z", "C"), float(self._pressed("T"))),
            select=float(glfw.get_mouse_button(window, glfw.MOUSE_BUTTON_LEFT) == glfw.PRESS),
            play_pause=self._pressed("SPACE"),
            next_preset=self._pressed("N"),
            toggle_lambert=self._pressed("L"),
            aim=aim,
        )
        return InputState(left=left, right=right)


def _looking_from(position, target) -> Pose:
    dx, dy, dz = (float(t - p) for t, p in zip(target, position, strict=True))
    yaw = math.atan2(-dx, -dz)
    pitch = math.atan2(dy, math.hypot(dx, dz))
    return Pose.from_yaw_pitch(position, yaw, pitch)
