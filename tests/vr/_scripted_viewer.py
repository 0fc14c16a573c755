"""Runs the real frame loop with the desktop backend, its keyboard and mouse replaced by a
script of controller input, and prints what the editor would have received as JSON.

Used by test_frame_loop.py in a process of its own (a GLX context must not share a thread
with the suite's EGL one)."""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset
from sand_editor.vr.actions import HandInput, InputState
from sand_editor.vr.desktop import DesktopBackend, eye_size
from sand_editor.vr.glwindow import GLWindows
from sand_editor.vr.loop import FrameLoop, ViewerOptions
from sand_editor.vr.workbench import BUTTONS
from sand_editor.vr.xrmath import Pose


class RecordingLink:
    closed = False
    quit_asked = False

    def __init__(self):
        self.sent = []

    def poll(self):
        return []

    def send(self, **message):
        self.sent.append({**message, "at_s": time.perf_counter()})
        return True


class ScriptedBackend(DesktopBackend):
    def __init__(self, windows, size, script):
        super().__init__(windows, size)
        self.script = script
        self.frame_index = 0

    def _input(self, head):
        step = self.script(self.frame_index)
        self.frame_index += 1
        return step


def main() -> None:
    size = eye_size(0.1)
    windows = GLWindows((2 * size[0], size[1]), "scripted", visible=True)
    backend = None

    def aim_at(name: str) -> Pose:
        u0, v0, u1, v1 = BUTTONS[name].box
        panel = loop.workbench.panel
        point = (
            panel.center
            + ((u0 + u1) / 2 - 0.5) * panel.size[0] * panel.right
            + ((v0 + v1) / 2 - 0.5) * panel.size[1] * panel.up
        )
        # The aim pose is in tracking space: the loop turns it by the tracking origin's yaw
        # and moves it by its offset.
        origin_now = loop.stage.locomotion.origin
        to_tracking = origin_now.rotation().T
        world_from = point + 0.6 * panel.normal
        origin = to_tracking @ (world_from - np.asarray(origin_now.offset))
        direction = to_tracking @ (point - world_from)
        yaw = math.atan2(-direction[0], -direction[2])
        pitch = math.atan2(direction[1], math.hypot(direction[0], direction[2]))
        return Pose.from_yaw_pitch(origin, yaw, pitch)

    # Thrown forwards and a little up from a hand below the eyes: lands some 20 m ahead.
    throw = Pose.from_yaw_pitch((0.15, 1.2, -0.1), 0.0, math.radians(20.0))

    def script(frame: int) -> InputState:
        if 5 <= frame < 25:  # left stick right: the clock runs forwards
            return InputState(left=HandInput(stick=(1.0, 0.0)))
        if 30 <= frame < 34:  # aim at the Lambert button, then pull the trigger
            return InputState(left=HandInput(aim=aim_at("lambert"), select=float(frame >= 32)))
        if frame == 40:
            return InputState(right=HandInput(next_preset=True))
        if 50 <= frame < 58:  # right stick forward: aim the arc; let go: teleport
            return InputState(right=HandInput(stick=(0.0, 1.0), aim=throw))
        if 64 <= frame < 66:  # right stick right: one snap turn, however long it is held
            return InputState(right=HandInput(stick=(1.0, 0.0), aim=throw))
        if 70 <= frame < 78:  # the trigger held away from the panel: aim; released: teleport
            return InputState(right=HandInput(select=1.0, aim=throw))
        if frame == 84:
            return InputState(left=HandInput(bring_bench=True))
        if 88 <= frame < 92:  # the vignette's button on the brought bench, turned 30°
            return InputState(left=HandInput(aim=aim_at("comfort"), select=float(frame >= 90)))
        return InputState(right=HandInput(aim=throw))

    link = RecordingLink()
    options = ViewerOptions(
        preset=Preset.load(bundled_preset("paper-default")),
        preset_label="paper-default",
        hours=12.0,
        frames=int(sys.argv[1]),
        texture_size=256,
    )
    backend = ScriptedBackend(windows, size, script)
    loop = FrameLoop(backend, windows, link, options)
    try:
        loop.start()
        loop.run()
        report = loop.report()
        report["bench_at"] = [float(v) for v in loop.workbench.layout.origin]
        shown = loop.shown_preset.name
    finally:
        loop.close()
        windows.close()
    print(json.dumps({"sent": link.sent, "report": report, "shown_preset": shown}))


if __name__ == "__main__":
    main()
