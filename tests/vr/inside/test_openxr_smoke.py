"""Smoke test of the OpenXR path against Monado's simulated HMD.

Runs only inside tools/monado/run (see tests/vr/conftest.py): the runtime,
the GLX display and the cp313 venv exist only there.
"""

from __future__ import annotations

import ctypes
import time

import glfw
import moderngl
import pytest
import xr
from xr.utils.gl import GLXGraphicsBinding

from sand_editor.vr.xr_backend import create_instance, gl_requirements

pytestmark = pytest.mark.openxr

GL_RGBA8 = 0x8058
GL_SRGB8_ALPHA8 = 0x8C43
FRAMES = 30
STEREO = xr.ViewConfigurationType.PRIMARY_STEREO
# One colour per eye, so a swapped or unrendered eye shows up in the read-back.
EYE_COLOURS = [(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)]


def _get_hmd(instance: xr.Instance) -> xr.SystemId:
    return xr.get_system(instance, xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY))


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def test_runtime_reports_simulated_hmd():
    instance = create_instance()
    try:
        runtime = _text(xr.get_instance_properties(instance).runtime_name)
        system = _get_hmd(instance)
        system_name = _text(xr.get_system_properties(instance, system).system_name)
        view_configs = xr.enumerate_view_configurations(instance, system)
        views = xr.enumerate_view_configuration_views(instance, system, STEREO)
        print(f"runtime {runtime!r}, system {system_name!r}")
        assert "Monado" in runtime
        assert "Simulated" in system_name
        assert STEREO in [xr.ViewConfigurationType(v) for v in view_configs]
        assert len(views) == 2
        for view in views:
            assert view.recommended_image_rect_width > 0
            assert view.recommended_image_rect_height > 0
    finally:
        xr.destroy_instance(instance)


class _GlfwContext:
    """A hidden GLFW window: its GLX context is the one the session renders with."""

    def __init__(self, major: int, minor: int):
        if not glfw.init():
            raise RuntimeError("glfw.init() failed (is DISPLAY set?)")
        glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
        glfw.window_hint(glfw.DOUBLEBUFFER, glfw.FALSE)
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, major)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, minor)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        self.window = glfw.create_window(64, 64, "sand-editor-vr-smoke", None, None)
        if not self.window:
            glfw.terminate()
            raise RuntimeError("could not create a GLX context on the Xvfb display")
        self.make_current()
        # A vsynced desktop context would throttle the OpenXR frame loop.
        glfw.swap_interval(0)

    def make_current(self) -> None:
        glfw.make_context_current(self.window)

    def destroy(self) -> None:
        if self.window:
            glfw.destroy_window(self.window)
            self.window = None
        glfw.terminate()


def test_gl_session_renders_frames_through_moderngl():
    instance = create_instance()
    cleanup = []
    try:
        system = _get_hmd(instance)
        req = gl_requirements(instance, system)
        min_major = req.min_api_version_supported.major
        assert min_major <= 4, f"runtime wants OpenGL {min_major}.x"

        gl = _GlfwContext(4, 5)
        cleanup.append(gl.destroy)
        binding = GLXGraphicsBinding(gl)
        ctx = moderngl.create_context()
        cleanup.append(ctx.release)
        print(f"GL {ctx.info['GL_VERSION']} on {ctx.info['GL_RENDERER']}")

        session = xr.create_session(
            instance, xr.SessionCreateInfo(next=binding.pointer, system_id=system)
        )
        cleanup.append(lambda: xr.destroy_session(session))
        space = xr.create_reference_space(
            session,
            xr.ReferenceSpaceCreateInfo(reference_space_type=xr.ReferenceSpaceType.LOCAL),
        )
        cleanup.append(lambda: xr.destroy_space(space))

        formats = list(xr.enumerate_swapchain_formats(session))
        offered = [f for f in (GL_RGBA8, GL_SRGB8_ALPHA8) if f in formats]
        assert offered, f"neither GL_RGBA8 nor GL_SRGB8_ALPHA8 in {[hex(f) for f in formats]}"
        colour_format = offered[0]

        eyes = []
        for view in xr.enumerate_view_configuration_views(instance, system, STEREO):
            size = (view.recommended_image_rect_width, view.recommended_image_rect_height)
            swapchain = xr.create_swapchain(
                session,
                xr.SwapchainCreateInfo(
                    usage_flags=xr.SwapchainUsageFlags.COLOR_ATTACHMENT_BIT
                    | xr.SwapchainUsageFlags.SAMPLED_BIT,
                    format=colour_format,
                    sample_count=1,
                    width=size[0],
                    height=size[1],
                    face_count=1,
                    array_size=1,
                    mip_count=1,
                ),
            )
            cleanup.append(lambda sc=swapchain: xr.destroy_swapchain(sc))
            images = xr.enumerate_swapchain_images(swapchain, xr.SwapchainImageOpenGLKHR)
            framebuffers = []
            for image in images:
                texture = ctx.external_texture(image.image, size, 4, 0, "f1")
                framebuffers.append(ctx.framebuffer(color_attachments=[texture]))
            eyes.append((swapchain, size, framebuffers))
        assert len(eyes) == 2

        states: list[xr.SessionState] = []
        running = False
        exiting = False
        exit_requested = False
        rendered = 0
        last_pixels: list[bytes] = [b"", b""]
        t_first = t_last = None
        deadline = time.monotonic() + 60

        def poll_events():
            nonlocal running, exiting
            while True:
                try:
                    event = xr.poll_event(instance)
                except xr.EventUnavailable:
                    return
                if event.type != xr.StructureType.EVENT_DATA_SESSION_STATE_CHANGED:
                    continue
                changed = ctypes.cast(
                    ctypes.byref(event), ctypes.POINTER(xr.EventDataSessionStateChanged)
                ).contents
                state = xr.SessionState(changed.state)
                states.append(state)
                if state == xr.SessionState.READY:
                    xr.begin_session(session, xr.SessionBeginInfo(STEREO))
                    running = True
                elif state == xr.SessionState.STOPPING:
                    xr.end_session(session)
                    running = False
                elif state in (xr.SessionState.EXITING, xr.SessionState.LOSS_PENDING):
                    exiting = True

        while not exiting:
            assert time.monotonic() < deadline, f"stuck; states so far {states}"
            poll_events()
            if not running:
                time.sleep(0.01)
                continue
            if not exit_requested and rendered >= FRAMES and xr.SessionState.FOCUSED in states:
                xr.request_exit_session(session)
                exit_requested = True
            frame_state = xr.wait_frame(session)
            xr.begin_frame(session)
            layers = []
            if frame_state.should_render:
                _, views = xr.locate_views(
                    session,
                    xr.ViewLocateInfo(
                        view_configuration_type=STEREO,
                        display_time=frame_state.predicted_display_time,
                        space=space,
                    ),
                )
                projection_views = []
                for eye, (view, (swapchain, size, framebuffers)) in enumerate(
                    zip(views, eyes, strict=True)
                ):
                    index = xr.acquire_swapchain_image(swapchain, xr.SwapchainImageAcquireInfo())
                    xr.wait_swapchain_image(
                        swapchain, xr.SwapchainImageWaitInfo(timeout=xr.INFINITE_DURATION)
                    )
                    fbo = framebuffers[index]
                    fbo.use()
                    fbo.clear(*EYE_COLOURS[eye], 1.0)
                    last_pixels[eye] = fbo.read(viewport=(0, 0, 1, 1), components=4)
                    ctx.screen.use()
                    xr.release_swapchain_image(swapchain, xr.SwapchainImageReleaseInfo())
                    projection_views.append(
                        xr.CompositionLayerProjectionView(
                            pose=view.pose,
                            fov=view.fov,
                            sub_image=xr.SwapchainSubImage(
                                swapchain=swapchain,
                                image_rect=xr.Rect2Di(extent=xr.Extent2Di(*size)),
                            ),
                        )
                    )
                layer = xr.CompositionLayerProjection(space=space, views=projection_views)
                layers.append(ctypes.byref(layer))
                rendered += 1
                now = time.monotonic()
                t_first = t_first or now
                t_last = now
            xr.end_frame(
                session,
                xr.FrameEndInfo(
                    display_time=frame_state.predicted_display_time,
                    environment_blend_mode=xr.EnvironmentBlendMode.OPAQUE,
                    layers=layers,
                ),
            )

        fps = (rendered - 1) / (t_last - t_first) if rendered > 1 else 0.0
        print(f"{rendered} frames at {fps:.1f} fps; states {[s.name for s in states]}")
        for wanted in ("READY", "SYNCHRONIZED", "VISIBLE", "FOCUSED", "STOPPING", "EXITING"):
            assert getattr(xr.SessionState, wanted) in states, f"{wanted} not in {states}"
        assert rendered >= FRAMES
        assert last_pixels[0][:3] == bytes([255, 0, 0]), last_pixels[0]
        assert last_pixels[1][:3] == bytes([0, 0, 255]), last_pixels[1]
    finally:
        for step in reversed(cleanup):
            step()
        xr.destroy_instance(instance)
