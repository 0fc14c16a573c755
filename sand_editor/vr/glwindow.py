"""GLX contexts from GLFW windows: the one the viewer renders with (visible for the desktop
preview, hidden for a headset) and a hidden one sharing its objects, for the thread that makes
new grain textures while frames keep being drawn."""

from __future__ import annotations

import os

import moderngl

REQUIRED_GL = (3, 3)


class WindowError(RuntimeError):
    """No window or OpenGL context could be made (no X display, no GL 3.3 driver)."""


def _glfw():
    import glfw

    # GLX is what OpenXR runtimes such as SteamVR take; Wayland would give EGL.
    if hasattr(glfw, "PLATFORM") and hasattr(glfw, "PLATFORM_X11"):
        glfw.init_hint(glfw.PLATFORM, glfw.PLATFORM_X11)
    return glfw


class GLWindows:
    """A main window with a GL 3.3+ core context, made current on this thread, and a hidden
    window whose context shares textures and programs with it (``worker``)."""

    def __init__(self, size: tuple[int, int], title: str, visible: bool) -> None:
        glfw = self.glfw = _glfw()
        if not os.environ.get("DISPLAY"):
            raise WindowError("no X display (DISPLAY is not set): the viewer needs one for GLX")
        if not glfw.init():
            raise WindowError(f"GLFW could not open the X display {os.environ['DISPLAY']!r}")
        self.window = self.worker = None
        try:
            glfw.default_window_hints()
            glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, REQUIRED_GL[0])
            glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, REQUIRED_GL[1])
            glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
            glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, glfw.TRUE)
            glfw.window_hint(glfw.VISIBLE, glfw.TRUE if visible else glfw.FALSE)
            # The eyes are laid out for this size: the preview keeps it.
            glfw.window_hint(glfw.RESIZABLE, glfw.FALSE)
            glfw.window_hint(glfw.DOUBLEBUFFER, glfw.TRUE if visible else glfw.FALSE)
            self.window = glfw.create_window(size[0], size[1], title, None, None)
            if not self.window:
                raise WindowError("could not create an OpenGL 3.3 core context on the display")
            glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
            self.worker = glfw.create_window(16, 16, f"{title} (grains)", None, self.window)
            if not self.worker:
                raise WindowError("could not create a second, shared OpenGL context")
            glfw.make_context_current(self.window)
            # A vsynced swap would throttle an OpenXR frame loop; the desktop preview is paced
            # by its own frame period.
            glfw.swap_interval(0)
            self.ctx = moderngl.create_context(require=330)
        except BaseException:
            self.close()
            raise

    def make_current(self) -> None:
        self.glfw.make_context_current(self.window)

    def close(self) -> None:
        glfw = self.glfw
        for window in (self.worker, self.window):
            if window:
                glfw.destroy_window(window)
        self.window = self.worker = None
        glfw.terminate()
