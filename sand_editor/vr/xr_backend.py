"""The headset: one OpenXR session through pyopenxr with OpenGL (``XR_KHR_opengl_enable``,
a GLX context from a hidden GLFW window), its actions and session life cycle; its swapchains are
in ``xr_swapchains``, the reading of its controllers in ``xr_input``.

pyopenxr raises qualified successes as exceptions: ``EventUnavailable`` ends an event poll,
``SessionNotFocused`` from ``sync_actions`` means no input this frame, ``FrameDiscarded`` means
the runtime dropped a frame (the loop goes on), ``SessionLossPending`` means the session ends.
"""

from __future__ import annotations

import ctypes
import time
from contextlib import ExitStack, contextmanager, suppress

import xr

from sand_editor.vr.actions import ACTIONS, BINDINGS, HANDS, InputState, binding_paths
from sand_editor.vr.backend import EyeView, Frame
from sand_editor.vr.errors import RUNTIME_HELP, GraphicsError, NoHeadsetError, NoRuntimeError
from sand_editor.vr.xr_input import ControllerInput, as_pose
from sand_editor.vr.xr_swapchains import STEREO, EyeSwapchains
from sand_editor.vr.xrmath import FAR_M, NEAR_M, Fov

_ACTION_TYPES = {
    "boolean": xr.ActionType.BOOLEAN_INPUT,
    "float": xr.ActionType.FLOAT_INPUT,
    "vector2f": xr.ActionType.VECTOR2F_INPUT,
    "pose": xr.ActionType.POSE_INPUT,
}
_RUNTIME_ERRORS = (xr.RuntimeUnavailableError, xr.RuntimeFailureError)
_HEADSET_ERRORS = (xr.FormFactorUnavailableError, xr.FormFactorUnsupportedError)


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


# Enabled where the runtime offers them: depth layers for its reprojection, and the display's
# refresh rate (the report's display periods per frame; predictedDisplayPeriod is the runtime's
# pacing period for the app, a whole number of refreshes, not the refresh).
OPTIONAL_EXTENSIONS = (
    xr.KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME,
    xr.FB_DISPLAY_REFRESH_RATE_EXTENSION_NAME,
)


def create_instance(enabled: list[str] | None = None) -> xr.Instance:
    """An instance with OpenGL (and the optional extensions where offered); ``NoRuntimeError``
    when no runtime is installed or active. ``enabled``, given, gets the extensions' names."""
    try:
        available = xr.enumerate_instance_extension_properties()
        if xr.KHR_OPENGL_ENABLE_EXTENSION_NAME not in available:
            raise GraphicsError(
                "the active OpenXR runtime does not offer OpenGL (XR_KHR_opengl_enable)"
            )
        extensions = [xr.KHR_OPENGL_ENABLE_EXTENSION_NAME]
        for optional in OPTIONAL_EXTENSIONS:
            if optional in available:
                extensions.append(optional)
        if enabled is not None:
            enabled[:] = extensions
        return xr.create_instance(
            xr.InstanceCreateInfo(
                application_info=xr.ApplicationInfo(
                    application_name="Sand Editor",
                    engine_name="sand-editor",
                    api_version=xr.Version(1, 0, xr.XR_VERSION_PATCH),
                ),
                enabled_extension_names=extensions,
            )
        )
    except _RUNTIME_ERRORS as exc:
        reason = f"no OpenXR runtime found ({type(exc).__name__})"
        raise NoRuntimeError(f"{reason}. {RUNTIME_HELP}") from None
    except xr.XrException as exc:
        reason = f"the OpenXR runtime failed to start ({exc})"
        raise NoRuntimeError(f"{reason}. {RUNTIME_HELP}") from None


def create_actions(instance, hand_paths) -> tuple:
    """The viewer's action set and its actions (``ACTIONS``), each per hand."""
    action_set = xr.create_action_set(
        instance,
        xr.ActionSetCreateInfo(
            action_set_name="sand_viewer", localized_action_set_name="Sand viewer", priority=0
        ),
    )
    actions = {
        name: xr.create_action(
            action_set,
            xr.ActionCreateInfo(
                action_name=name,
                action_type=_ACTION_TYPES[kind],
                subaction_paths=hand_paths,
                localized_action_name=label,
            ),
        )
        for name, (kind, label) in ACTIONS.items()
    }
    return action_set, actions


def suggest_bindings(instance, actions: dict, profile: str, pairs) -> None:
    """Suggest (action, input path) pairs for an interaction profile; the runtime raises if
    it rejects any of them (and then the whole profile)."""
    xr.suggest_interaction_profile_bindings(
        instance,
        xr.InteractionProfileSuggestedBinding(
            interaction_profile=xr.string_to_path(instance, profile),
            suggested_bindings=[
                xr.ActionSuggestedBinding(actions[action], xr.string_to_path(instance, path))
                for action, path in pairs
            ],
        ),
    )


class XrBackend:
    name = "xr"

    def __init__(self, windows_factory, render_scale: float) -> None:
        """``windows_factory()`` makes the GL windows (after the instance and system, so a
        missing runtime or headset is reported before any window opens).

        Each resource's release is pushed on ``_teardown`` as it is created; ``close`` (or a
        failure while starting) releases them in reverse order."""
        self._teardown = ExitStack()
        self.exiting = False
        enabled: list[str] = []
        self.instance = create_instance(enabled)
        self.depth_offered = xr.KHR_COMPOSITION_LAYER_DEPTH_EXTENSION_NAME in enabled
        self._refresh_offered = xr.FB_DISPLAY_REFRESH_RATE_EXTENSION_NAME in enabled
        self.display_refresh_hz: float | None = None
        self._teardown.callback(xr.destroy_instance, self.instance)
        try:
            self._start(windows_factory, render_scale)
        except BaseException:
            self.close()
            raise

    def _start(self, windows_factory, render_scale: float) -> None:
        instance = self.instance
        self.runtime = _text(xr.get_instance_properties(instance).runtime_name)
        try:
            self.system_id = xr.get_system(
                instance, xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY)
            )
        except _HEADSET_ERRORS as exc:
            raise NoHeadsetError(
                f"the OpenXR runtime {self.runtime!r} has no headset ({type(exc).__name__}): "
                "connect and switch on the headset, or use sand-editor vr --desktop"
            ) from None
        self.system = _text(xr.get_system_properties(instance, self.system_id).system_name)
        requirements = gl_requirements(instance, self.system_id)
        self.windows = windows_factory()
        self._teardown.callback(self.windows.close)
        self.ctx = self.windows.ctx
        from xr.utils.gl import GLXGraphicsBinding

        binding = GLXGraphicsBinding(self.windows)
        try:
            self.session = xr.create_session(
                instance, xr.SessionCreateInfo(next=binding.pointer, system_id=self.system_id)
            )
        except xr.XrException as exc:
            minimum = requirements.min_api_version_supported
            raise GraphicsError(
                f"the OpenXR runtime refused an OpenGL session ({exc}); it needs OpenGL "
                f"{minimum.major}.{minimum.minor} or newer, this context is "
                f"{self.ctx.info['GL_VERSION']}"
            ) from None
        self._teardown.callback(xr.destroy_session, self.session)
        if self._refresh_offered:
            rate = float(xr.get_display_refresh_rate_fb(self.session).value)
            self.display_refresh_hz = rate if rate > 0 else None
        spaces = list(xr.enumerate_reference_spaces(self.session))
        self.floor_level = xr.ReferenceSpaceType.STAGE in spaces
        space_type = (
            xr.ReferenceSpaceType.STAGE if self.floor_level else (xr.ReferenceSpaceType.LOCAL)
        )
        self.reference_space = space_type.name
        self.space = xr.create_reference_space(
            self.session, xr.ReferenceSpaceCreateInfo(reference_space_type=space_type)
        )
        self._teardown.callback(xr.destroy_space, self.space)
        self._swapchains = EyeSwapchains(
            instance, self.system_id, self.session, self.ctx, render_scale, self._teardown,
            depth=self.depth_offered, near_far=(NEAR_M, FAR_M),
        )  # fmt: skip
        self.swapchain_format = self._swapchains.format
        self.depth_format = self._swapchains.depth_format
        self.depth_submitted = self._swapchains.depth_submitted
        self.views = self._swapchains.views
        self._create_actions()
        self._running = False
        self.lost = False
        self._state = "IDLE"
        self._focused = False
        self._exit_requested = False
        self._frame_state = None
        self._views = None
        self._projection_views = []

    # ---- set-up ----------------------------------------------------------------------------

    def _create_actions(self) -> None:
        instance = self.instance
        self._hand_paths = {
            hand: xr.string_to_path(instance, f"/user/hand/{hand}") for hand in HANDS
        }
        self.action_set, self.actions = create_actions(instance, list(self._hand_paths.values()))
        self._teardown.callback(xr.destroy_action_set, self.action_set)
        self.suggested_profiles = {}
        for profile in BINDINGS:
            try:
                suggest_bindings(instance, self.actions, profile, binding_paths(profile))
                self.suggested_profiles[profile] = "accepted"
            except xr.XrException as exc:
                # One unknown path rejects the whole profile; the others still work.
                self.suggested_profiles[profile] = f"{type(exc).__name__}: {exc}"
        xr.attach_session_action_sets(
            self.session, xr.SessionActionSetsAttachInfo(action_sets=[self.action_set])
        )
        self._controllers = ControllerInput(
            self.session,
            self.space,
            self.action_set,
            self.actions,
            self._hand_paths,
            self._teardown,
        )

    # ---- session life cycle --------------------------------------------------------------------

    def poll_events(self) -> list[str]:
        entered = []
        while True:
            try:
                event = xr.poll_event(self.instance)
            except xr.EventUnavailable:
                return entered
            kind = xr.StructureType(event.type)
            if kind == xr.StructureType.EVENT_DATA_INSTANCE_LOSS_PENDING:
                self._lose()
                entered.append("INSTANCE_LOSS_PENDING")
                continue
            if kind != xr.StructureType.EVENT_DATA_SESSION_STATE_CHANGED:
                continue
            changed = ctypes.cast(
                ctypes.byref(event), ctypes.POINTER(xr.EventDataSessionStateChanged)
            ).contents
            state = xr.SessionState(changed.state)
            self._state = state.name
            entered.append(state.name)
            if state == xr.SessionState.READY:
                xr.begin_session(self.session, xr.SessionBeginInfo(STEREO))
                self._running = True
                if self._exit_requested:
                    xr.request_exit_session(self.session)
            elif state == xr.SessionState.STOPPING:
                xr.end_session(self.session)
                self._running = False
            elif state == xr.SessionState.LOSS_PENDING:
                self._lose()
            elif state == xr.SessionState.EXITING:
                self._running = False
                self.exiting = True
            self._focused = state == xr.SessionState.FOCUSED

    def _lose(self) -> None:
        """The runtime is taking the session away (headset unplugged, runtime stopping)."""
        self.lost = True
        self._running = False
        self.exiting = True

    def request_exit(self) -> None:
        if self._exit_requested:
            return
        self._exit_requested = True
        if self._running:
            xr.request_exit_session(self.session)
        elif self._state in ("IDLE", "UNKNOWN"):
            # Never started: nothing to stop.
            self.exiting = True

    def interaction_profiles(self) -> dict[str, str | None]:
        bound = {}
        for hand, path in self._hand_paths.items():
            try:
                state = xr.get_current_interaction_profile(self.session, path)
                profile = state.interaction_profile
                bound[hand] = xr.path_to_string(self.instance, profile) if profile else None
            except xr.XrException:
                bound[hand] = None
        return bound

    # ---- frames --------------------------------------------------------------------------------

    def wait_frame(self) -> Frame | None:
        if not self._running:
            return None
        try:
            frame_state = xr.wait_frame(self.session)
        except xr.SessionLossPending:
            self._lose()
            return None
        try:
            xr.begin_frame(self.session)
        except xr.FrameDiscarded:
            pass  # the previous frame was dropped; this one has begun all the same
        self._frame_state = frame_state
        display_time = frame_state.predicted_display_time
        eyes = []
        if frame_state.should_render:
            _, views = xr.locate_views(
                self.session,
                xr.ViewLocateInfo(
                    view_configuration_type=STEREO, display_time=display_time, space=self.space
                ),
            )
            self._views = views
            for index, view in enumerate(views):
                fov = Fov(
                    view.fov.angle_left,
                    view.fov.angle_right,
                    view.fov.angle_up,
                    view.fov.angle_down,
                )
                self.views[index]["fov"] = fov.as_dict()
                eyes.append(EyeView(as_pose(view.pose), fov))
        self._projection_views = []
        start = time.perf_counter()
        controls = self._controllers.read(display_time) if self._focused else InputState()
        input_ms = (time.perf_counter() - start) * 1e3
        period = frame_state.predicted_display_period * 1e-9
        if self.display_refresh_hz is not None:
            period = 1.0 / self.display_refresh_hz
        return Frame(display_time * 1e-9, bool(frame_state.should_render), eyes, controls,
                     input_ms, period if period > 0 else 1 / 90)  # fmt: skip

    @contextmanager
    def eye_target(self, index: int):
        with self._swapchains.image(index) as target:
            yield target
        self._projection_views.append(self._swapchains.projection_view(index, self._views[index]))

    def end_frame(self, frame: Frame, rendered: bool) -> None:
        layers = []
        if rendered and len(self._projection_views) == len(self._swapchains):
            # Kept alive until end_frame returns: the runtime reads it there.
            layer = xr.CompositionLayerProjection(space=self.space, views=self._projection_views)
            layers.append(ctypes.byref(layer))
        try:
            xr.end_frame(
                self.session,
                xr.FrameEndInfo(
                    display_time=self._frame_state.predicted_display_time,
                    environment_blend_mode=xr.EnvironmentBlendMode.OPAQUE,
                    layers=layers,
                ),
            )
        except xr.FrameDiscarded:
            pass
        self._projection_views = []

    # ---- end -------------------------------------------------------------------------------------

    def close(self) -> None:
        """Release what was created, newest first. A release that fails does not stop the
        others (the stack runs every callback), and its error is dropped: tearing down."""
        with suppress(Exception):
            self._teardown.close()


def gl_requirements(instance, system_id):
    """``xrGetOpenGLGraphicsRequirementsKHR``, which the spec requires before
    ``xrCreateSession`` with OpenGL (called directly: pyopenxr's wrapper module refers to
    Windows-only types at import)."""
    function = ctypes.cast(
        xr.get_instance_proc_addr(instance, "xrGetOpenGLGraphicsRequirementsKHR"),
        xr.PFN_xrGetOpenGLGraphicsRequirementsKHR,
    )
    requirements = xr.GraphicsRequirementsOpenGLKHR()
    result = xr.check_result(xr.Result(function(instance, system_id, ctypes.byref(requirements))))
    if result.is_exception():
        raise result
    return requirements
