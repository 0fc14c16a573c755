"""The frame loop shared by the headset and the desktop preview.

A backend (``xr_backend.XrBackend`` or ``desktop.DesktopBackend``) supplies session states,
frames with eye poses and fields of view, controller input and one framebuffer per eye; the loop
does everything else: the link, the controls, the view model (clock and mode, shared with the
editor over the link), new grains off the loop, the scene
chosen once per frame from the head, each eye through the one ``SandRenderer``, and the report.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sand_editor.generator.sizes import DEFAULT_RENDER_SIZE
from sand_editor.gl import finish_without_gil
from sand_editor.preset import Preset, PresetError
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.resources import presets_dir
from sand_editor.view import CLOCK, TIME_FIELDS, ViewModel, ViewState
from sand_editor.vr._files import read_pixels, save_side_by_side
from sand_editor.vr._messages import LINK, answer_error, handle_link
from sand_editor.vr._report import FrameStats, count_levels_of_detail, loop_report
from sand_editor.vr._resources import gl_object_counts, resident_mb
from sand_editor.vr.actions import (
    Command,
    CommandKind,
    InputState,
    ViewerControls,
    apply_command,
    commands_from_input,
)
from sand_editor.vr.backend import Frame
from sand_editor.vr.errors import NoHeadsetError
from sand_editor.vr.grains import GrainWorker
from sand_editor.vr.stage import STANDING_EYE_HEIGHT_M, Stage, between
from sand_editor.vr.xrmath import FAR_M, NEAR_M, Fov, Pose, eye_camera

INPUT = "input"  # the source of view changes made by the controllers, the keys or the panel
TIME_MESSAGE_INTERVAL_S = 0.2  # at most ~5 time messages a second while scrubbing
MAX_FRAME_STEP_S = 0.25  # a stalled frame does not make the day jump
SESSION_NOTICE_S = 10.0  # waiting this long for the session to run: tell the user
SESSION_TIMEOUT_S = 60.0  # ... and give up with --frames (tests, support runs)
WARM_UP_FRAMES = 50  # the report's resource counts are taken here and at the end
START_TIMEOUT_S = 120.0  # the first grains must come within this
START_POLL_S = 0.05  # ... and the start-up looks for the editor's "quit" this often


@dataclass
class ViewerOptions:
    preset: Preset
    preset_label: str
    hours: float = 10.0
    day_speed: float = 0.0
    mode: str = "full"
    frames: int | None = None
    texture_size: int = DEFAULT_RENDER_SIZE
    screenshot: Path | None = None
    comfort: bool = True  # the vignette over teleports and snap turns


class FrameLoop:
    def __init__(self, backend, windows, link, options: ViewerOptions) -> None:
        self.backend = backend
        self.link = link
        self.options = options
        self.ctx = windows.ctx
        self.stats = FrameStats()
        self.presets = _preset_list(options.preset, options.preset_label)
        self.controls = ViewerControls(
            preset_index=0, preset_count=len(self.presets), comfort=options.comfort
        )
        self.view = ViewModel(
            ViewState(
                hours=options.hours,
                day_speed=options.day_speed,
                playing=options.day_speed > 0,
                mode=options.mode,
            )
        )
        self.view.connect(self._view_changed)
        self.renderer = SandRenderer(self.ctx)
        self.renderer.exposure.adapt_over_time = True
        self.stage = Stage(self.ctx, self.renderer, backend.floor_level)
        self.worker = GrainWorker(windows.glfw, windows.worker, options.texture_size)
        self.material = None
        self.shown_preset: Preset | None = None
        self.pending: tuple[int | None, float] | None = None  # (seq, received) of a request
        self.previous_input = InputState()
        self.previous_time: float | None = None
        self._sky = None  # (hours, the sky at them): drawn again only when the clock moves
        self.time_dirty_since: float | None = None
        self.last_time_message = 0.0
        self.ready_sent = False
        self.pending_applied: tuple[int | None, float, str] | None = None
        self.resources: dict[str, dict] = {}
        self._builds_before_loop = 0
        self._waiting_since: float | None = None
        self._waiting_noticed = False
        self.stop_requested = False  # set from a signal handler: end the session cleanly

    # ---- start and end -------------------------------------------------------------------

    def start(self) -> bool:
        """The first material, made before the first frame (a frame needs grains). False when
        the editor asked the viewer to quit meanwhile (it reads no messages until the loop
        runs): there is nothing to run then."""
        self.worker.request(self.presets[0][1])
        deadline = time.monotonic() + START_TIMEOUT_S
        ready = None
        while ready is None and time.monotonic() < deadline:
            if self.link.quit_asked:
                return False
            ready = self.worker.wait(timeout_s=START_POLL_S)
        if ready is None or ready.material is None:
            reason = "timed out" if ready is None else ready.error
            raise RuntimeError(f"could not make the grain textures: {reason}")
        self._show(ready.material, ready.preset)
        if self.link.quit_asked:
            return False
        self._warm_up()
        self._builds_before_loop = self.renderer.terrain_meshes_built
        return True

    def _warm_up(self) -> None:
        """Draw once off screen: compiling programs and the rasterizer's first draws take
        seconds on a CPU, and a headset must not wait that long for a frame."""
        texture = self.ctx.texture((64, 48), 4)
        target = self.ctx.framebuffer([texture])
        try:
            pose = Pose((0.0, STANDING_EYE_HEIGHT_M, 0.0))
            camera = eye_camera(pose, Fov.symmetric(1.4, 4 / 3), NEAR_M, FAR_M)
            scene = self.renderer.prepare_frame(camera, show_sphere=False)
            state = self.view.state
            request = FrameRequest(camera, sky_at(state.hours), scene=scene,
                                   extra=self.stage.props([pose]), depth_out=True)  # fmt: skip
            self.renderer.render(target, request)
            target.use()
            self.stage.overlay(camera, (0, 0, 64, 48), state, "", [pose], comfort=True)
            finish_without_gil()
        finally:
            # Nothing may stay bound to a released framebuffer (the next draw restores it).
            self.ctx.screen.use()
            target.release()
            texture.release()

    def close(self) -> None:
        self.worker.close()
        self.stage.release()
        self.renderer.release()

    # ---- the loop ----------------------------------------------------------------------------

    def run(self) -> None:
        backend = self.backend
        stats = self.stats
        while not backend.exiting:
            if self.stop_requested:
                backend.request_exit()
            for state in backend.poll_events():
                stats.states.append(state)
                self.link.send(type="state", state=state)
            handle_link(self)
            regenerating = self.pending is not None or self.worker.busy
            wait_start = time.perf_counter()
            frame = backend.wait_frame()
            if frame is None:
                self._waiting_for_session()
                time.sleep(0.005)
                continue
            loop_start = time.perf_counter()
            stats.wait_ms.append((loop_start - wait_start) * 1e3 - frame.input_ms)
            eye_ms = self._frame(frame)
            submit_start = time.perf_counter()
            own_ms = (submit_start - loop_start) * 1e3 - sum(eye_ms or ()) + frame.input_ms
            stats.overhead_ms.append(own_ms)
            backend.end_frame(frame, rendered=eye_ms is not None)
            now = time.perf_counter()
            stats.submit_ms.append((now - submit_start) * 1e3)
            self._after_submit(now, frame, regenerating)
            if stats.frames_submitted == WARM_UP_FRAMES:
                self.resources["after_warm_up"] = self._resources()
                # Counting GL objects is the report's own work: not a gap between frames.
                stats.last_submit = time.perf_counter()
            if self.options.frames is not None and stats.frames_submitted >= self.options.frames:
                backend.request_exit()

    def _waiting_for_session(self) -> None:
        """Before the runtime runs the session (a headset off or not worn keeps it IDLE): say
        so after a while, and give up after longer when a number of frames was asked for."""
        if self.stats.frames_submitted:
            return
        now = time.perf_counter()
        if self._waiting_since is None:
            self._waiting_since = now
        waited = now - self._waiting_since
        state = self.stats.states[-1] if self.stats.states else "none yet"
        if waited > SESSION_NOTICE_S and not self._waiting_noticed:
            self._waiting_noticed = True
            print(
                f"sand-editor vr: waiting for the OpenXR runtime to start the session "
                f"(state {state}): is the headset on and worn?",
                file=sys.stderr,
            )
        if self.options.frames is not None and waited > SESSION_TIMEOUT_S:
            raise NoHeadsetError(
                f"the OpenXR runtime did not start the session within {SESSION_TIMEOUT_S:.0f} s "
                f"(state {state}): switch the headset on and put it on, or use --desktop"
            )

    def _frame(self, frame: Frame) -> list[float] | None:
        dt = 0.0
        if self.previous_time is not None:
            step = frame.display_time_s - self.previous_time
            dt = min(max(step, 0.0), MAX_FRAME_STEP_S)
            self.stats.display_periods.append(step / frame.display_period_s)
        self.previous_time = frame.display_time_s
        self._take_new_material()
        self.stage.track(frame)
        self._apply_input(frame.input, dt)
        self.view.tick(dt)
        if not frame.should_render or not frame.eyes:
            return None
        eyes = self.stage.world_eyes(frame.eyes)
        cameras = [eye_camera(e.pose, e.fov, NEAR_M, FAR_M) for e in eyes]
        head = eye_camera(between(eyes), eyes[0].fov, NEAR_M, FAR_M)
        count_levels_of_detail(self.stats, self.renderer, head, cameras)
        scene = self.renderer.prepare_frame(head, show_sphere=False)
        state = self.view.state
        if self._sky is None or self._sky[0] != state.hours:  # the clock may stand still
            self._sky = (state.hours, sky_at(state.hours))
        sky = self._sky[1]
        hands, rays = self.stage.rays(frame.input)
        props = self.stage.props(hands)
        name = self.presets[self._index()][0]
        screenshot = self._wants_screenshot()
        images = []
        eye_ms = []
        exposure = None  # metered by the first eye; the second keeps it, or the eyes would differ
        for index, camera in enumerate(cameras):
            start = time.perf_counter()
            with self.backend.eye_target(index) as (target, viewport):
                request = FrameRequest(camera, sky, state.mode, viewport, exposure, scene=scene,
                                       extra=props, depth_out=True)  # fmt: skip
                exposure = self.renderer.render(target, request)["exposure"]
                target.use()
                self.stage.overlay(camera, viewport, state, name, rays, self.controls.comfort)
                finish_without_gil()
                if screenshot:
                    images.append(read_pixels(target, viewport))
            eye_ms.append((time.perf_counter() - start) * 1e3)
        if len(cameras) == 2 and np.allclose(cameras[0].view, cameras[1].view):
            self.stats.views_differ = False
        self.stats.eye_ms.extend(eye_ms)
        self.stats.frames_rendered += 1
        if screenshot:
            save_side_by_side(images, self.options.screenshot)
        return eye_ms

    def _after_submit(self, now: float, frame: Frame, regenerating: bool) -> None:
        stats = self.stats
        stats.frames_submitted += 1
        if stats.last_submit is not None:
            gap = (now - stats.last_submit) * 1e3
            stats.gaps_ms.append(gap)
            if gap >= max(stats.gaps_ms):
                stats.max_gap_frame = stats.frames_submitted
            if regenerating or self.pending is not None or self.worker.busy:
                stats.regenerating_gaps_ms.append(gap)
        stats.last_submit = now
        if not self.ready_sent:
            self.ready_sent = True
            backend = self.backend
            self.link.send(
                type="ready",
                backend=backend.name,
                runtime=backend.runtime,
                system=backend.system,
                views=[{"width": v["width"], "height": v["height"]} for v in backend.views],
            )
            self._send_time()
        if self.pending_applied is not None and frame.should_render:
            seq, received, grains = self.pending_applied
            ms = round((now - received) * 1e3, 1)
            self.link.send(type="applied", seq=seq, ms=ms, grains=grains)
            self.pending_applied = None
        if self.time_dirty_since is not None and now - self.last_time_message >= (
            TIME_MESSAGE_INTERVAL_S
        ):
            self._send_time()

    # ---- input ---------------------------------------------------------------------------------

    def _apply_input(self, state: InputState, dt: float) -> None:
        self.stage.aim_hands(state)
        for command in commands_from_input(self.previous_input, state, dt):
            self.run_command(command)
        self.stage.locomote(self.previous_input, state)
        self.previous_input = state

    def run_command(self, command: Command) -> None:
        """The one dispatcher of commands, from the controllers, the keys, the panel or the
        link: a trigger pulled presses the panel button it aims at (away from the panel it aims
        a teleport, which ``Stage.locomote`` does), the bench is the stage's to bring, and the
        rest change the controls and the view."""
        match command.kind:
            case CommandKind.PRESS:
                pressed = self.workbench.press(command.hand)
                if pressed is not None:
                    self.run_command(pressed)
            case CommandKind.BRING_BENCH:
                self.stage.bring_bench()
            case _:
                before = self.controls
                self.controls, changes = apply_command(self.controls, self.view.state, command)
                self.view.update(INPUT, **changes)
                if self.controls.preset_index != before.preset_index:
                    self.worker.request(self.presets[self._index()][1])

    @property
    def workbench(self):
        return self.stage.workbench

    def move(self, **fields) -> None:
        """A ``move`` from the link (``Stage.move``)."""
        self.stage.move(**fields)

    def _view_changed(self, state: ViewState, names: frozenset, source) -> None:
        """What the user changed here goes to the editor (the clock's ticks do not: the editor
        runs its own clock; nor what the editor set)."""
        if source in (LINK, CLOCK):
            return
        if names & TIME_FIELDS:
            self.time_dirty_since = self.time_dirty_since or time.perf_counter()
        if "mode" in names:
            self.link.send(type="mode", mode=state.mode)

    def _send_time(self) -> None:
        c = self.view.state
        self.link.send(
            type="time", hours=round(c.hours, 4), day_speed=c.day_speed, playing=c.playing
        )
        self.last_time_message = time.perf_counter()
        self.time_dirty_since = None

    # ---- grains -------------------------------------------------------------------------------

    def _take_new_material(self) -> None:
        ready = self.worker.poll()
        if ready is None:
            return
        if self.pending is not None and self.pending[0] == ready.seq:
            self.pending = None
        if ready.note is not None:
            answer_error(self, f"the editor's grains not used, made here instead: {ready.note}")
        if ready.material is None:
            answer_error(self, f"preset {ready.preset.name!r}: {ready.error}; the old sand stays")
            return
        self.stats.grain_sources[ready.grains] += 1
        self._show(ready.material, ready.preset)
        if ready.seq is not None:
            self.pending_applied = (ready.seq, ready.received_s, ready.grains)

    def _show(self, material, preset: Preset) -> None:
        old = self.material
        self.material = material
        self.shown_preset = preset
        self.renderer.set_material(material)
        if old is not None:
            self.worker.give_back(old)

    # ---- helpers ------------------------------------------------------------------------------

    def _index(self) -> int:
        return self.controls.preset_index % len(self.presets)

    def _wants_screenshot(self) -> bool:
        if self.options.screenshot is None:
            return False
        last = self.options.frames or 1
        return self.stats.frames_submitted + 1 == last

    # ---- report -------------------------------------------------------------------------------

    def _resources(self) -> dict:
        return {
            "frame": self.stats.frames_submitted,
            "gl_objects": gl_object_counts(self.ctx),
            "resident_mb": round(resident_mb(), 1),
        }

    def report(self) -> dict:
        return loop_report(self)


def _preset_list(preset: Preset, label: str) -> list[tuple[str, Preset]]:
    """The preset shown first, then every shipped one (each once)."""
    entries = [(label, preset)]
    for path in sorted(presets_dir().glob("*.json")):
        if path.stem == label:
            continue
        try:
            entries.append((path.stem, Preset.load(path)))
        except PresetError:
            continue
    return entries
