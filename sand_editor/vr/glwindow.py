"""GLX contexts from GLFW windows: the one the viewer renders with (visible for the desktop
preview, hidden for a headset) and a hidden one sharing its objects, for the thread that makes
new grain textures while frames keep being drawn; and the same pair as EGL contexts with no
window (``HeadlessContexts``), where there is no display."""

from __future__ import annotations

import ctypes
import os

import moderngl

from sand_editor.gl import egl_library

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


class HeadlessContexts:
    """What ``GLWindows`` gives the frame loop, with no display: two EGL contexts sharing
    objects (with each other and with this thread's ``sand_editor.gl.standalone_context``, whose
    display they use), the drawing one (``ctx``) current on this thread and ``worker`` for the
    grain thread (``GrainWorker`` with ``glfw`` None).

    There is no window: the backend draws into framebuffers of its own (``vr.headless``), and
    ``ctx.screen`` is a framebuffer nothing is drawn into.
    """

    glfw = None

    def __init__(self) -> None:
        from sand_editor.gl import standalone_context

        standalone_context()
        self.worker = SharedEGLContext()
        self._drawing = SharedEGLContext()
        try:
            self.ctx = self._drawing.context()
        except BaseException:
            self._drawing.release()
            self.worker.release()
            raise

    def make_current(self) -> None:
        self._drawing.__enter__()

    def close(self) -> None:
        self.ctx.release()  # destroys the drawing context
        self.worker.release()


# EGL's names for what a shared context is asked to be: an OpenGL 3.3 core context like
# glcontext's headless one (8-bit RGB, a depth buffer, made for pbuffers it never draws into).
_EGL_NONE = 0x3038
_EGL_OPENGL_API = 0x30A2
_EGL_CONFIG = (
    (0x3033, 0x0001),  # EGL_SURFACE_TYPE: EGL_PBUFFER_BIT
    (0x3024, 8), (0x3023, 8), (0x3022, 8),  # EGL_RED_SIZE, EGL_GREEN_SIZE, EGL_BLUE_SIZE
    (0x3025, 8),  # EGL_DEPTH_SIZE
    (0x3040, 0x0008),  # EGL_RENDERABLE_TYPE: EGL_OPENGL_BIT
)  # fmt: skip
_EGL_CONTEXT = (
    (0x3098, REQUIRED_GL[0]),  # EGL_CONTEXT_MAJOR_VERSION
    (0x30FB, REQUIRED_GL[1]),  # EGL_CONTEXT_MINOR_VERSION
    (0x30FD, 0x0001),  # EGL_CONTEXT_OPENGL_PROFILE_MASK: core
)


class SharedEGLContext:
    """An EGL context sharing objects with the one current on the thread that makes it, for
    another thread: ``context()`` makes it current there and returns it as a moderngl context,
    whose ``release`` destroys it. It has no surface: it draws into framebuffers only."""

    def __init__(self) -> None:
        egl = self._egl = egl_library()
        if egl is None:
            raise WindowError("libEGL could not be loaded: no headless OpenGL")
        self._display = egl.eglGetCurrentDisplay()
        share = egl.eglGetCurrentContext()
        if not self._display or not share:
            raise WindowError("no EGL context is current on this thread to share objects with")
        config = ctypes.c_void_p()
        count = ctypes.c_int32()
        chosen = egl.eglChooseConfig(
            self._display, _attributes(_EGL_CONFIG), ctypes.byref(config), 1, ctypes.byref(count)
        )
        if not chosen or not count.value:
            raise WindowError(f"no EGL config for a shared context (0x{egl.eglGetError():x})")
        egl.eglBindAPI(_EGL_OPENGL_API)
        self._handle = egl.eglCreateContext(self._display, config, share, _attributes(_EGL_CONTEXT))
        if not self._handle:
            raise WindowError(f"could not create a shared EGL context (0x{egl.eglGetError():x})")

    def context(self) -> moderngl.Context:
        """This context, made current on the calling thread, as a moderngl context."""
        self.__enter__()
        return moderngl.create_context(require=330, context=self)

    # ---- what moderngl asks of a context it did not make ------------------------------------

    def load_opengl_function(self, name: str) -> int:
        return self._egl.eglGetProcAddress(name.encode()) or 0

    def __enter__(self) -> None:
        if not self._egl.eglMakeCurrent(self._display, None, None, self._handle):
            raise WindowError(f"eglMakeCurrent failed (0x{self._egl.eglGetError():x})")

    def __exit__(self, *exc_info) -> None:
        self._egl.eglMakeCurrent(self._display, None, None, None)

    def release(self) -> None:
        """Destroy the context (EGL waits until no thread has it current); the calling thread
        lets go of it first where it is current there."""
        if self._handle is None:
            return
        if self._egl.eglGetCurrentContext() == self._handle:
            self.__exit__()
        self._egl.eglDestroyContext(self._display, self._handle)
        self._handle = None


def _attributes(pairs: tuple[tuple[int, int], ...]):
    flat = [value for pair in pairs for value in pair]
    return (ctypes.c_int32 * (len(flat) + 1))(*flat, _EGL_NONE)
