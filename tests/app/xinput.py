"""Real keyboard input to another process's X window, through the XTEST extension (libXtst):
the server delivers it as if typed, so the receiving program cannot tell the difference."""

from __future__ import annotations

import ctypes
import ctypes.util
import time

_Window = ctypes.c_ulong
_Atom = ctypes.c_ulong


class _WindowAttributes(ctypes.Structure):
    _fields_ = [
        *((name, ctypes.c_int) for name in ("x", "y", "width", "height", "border", "depth")),
        ("visual", ctypes.c_void_p),
        ("root", _Window),
        *((name, ctypes.c_int) for name in ("class_", "bit_gravity", "win_gravity", "backing")),
        ("backing_planes", ctypes.c_ulong),
        ("backing_pixel", ctypes.c_ulong),
        ("save_under", ctypes.c_int),
        ("colormap", ctypes.c_ulong),
        ("map_installed", ctypes.c_int),
        ("map_state", ctypes.c_int),
        *((name, ctypes.c_long) for name in ("all_events", "your_events", "no_propagate")),
        ("override_redirect", ctypes.c_int),
        ("screen", ctypes.c_void_p),
    ]


_IS_VIEWABLE = 2


def _library(name: str) -> ctypes.CDLL:
    path = ctypes.util.find_library(name)
    if path is None:
        raise OSError(f"lib{name} is not installed")
    return ctypes.CDLL(path)


class XKeyboard:
    """One connection to the X server named by ``DISPLAY``."""

    def __init__(self) -> None:
        self._x11 = x11 = _library("X11")
        self._xtst = xtst = _library("Xtst")
        x11.XOpenDisplay.restype = ctypes.c_void_p
        x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
        x11.XDefaultRootWindow.restype = _Window
        x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
        x11.XInternAtom.restype = _Atom
        x11.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
        x11.XQueryTree.argtypes = [
            ctypes.c_void_p,
            _Window,
            ctypes.POINTER(_Window),
            ctypes.POINTER(_Window),
            ctypes.POINTER(ctypes.POINTER(_Window)),
            ctypes.POINTER(ctypes.c_uint),
        ]
        x11.XGetWindowProperty.argtypes = [
            ctypes.c_void_p,
            _Window,
            _Atom,
            ctypes.c_long,
            ctypes.c_long,
            ctypes.c_int,
            _Atom,
            ctypes.POINTER(_Atom),
            ctypes.POINTER(ctypes.c_int),
            ctypes.POINTER(ctypes.c_ulong),
            ctypes.POINTER(ctypes.c_ulong),
            ctypes.POINTER(ctypes.c_void_p),
        ]
        x11.XFree.argtypes = [ctypes.c_void_p]
        x11.XGetWindowAttributes.argtypes = [
            ctypes.c_void_p,
            _Window,
            ctypes.POINTER(_WindowAttributes),
        ]
        x11.XSetInputFocus.argtypes = [ctypes.c_void_p, _Window, ctypes.c_int, ctypes.c_ulong]
        x11.XStringToKeysym.restype = ctypes.c_ulong
        x11.XStringToKeysym.argtypes = [ctypes.c_char_p]
        x11.XKeysymToKeycode.restype = ctypes.c_ubyte
        x11.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
        x11.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
        x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
        xtst.XTestFakeKeyEvent.argtypes = [
            ctypes.c_void_p,
            ctypes.c_uint,
            ctypes.c_int,
            ctypes.c_ulong,
        ]
        self._display = x11.XOpenDisplay(None)
        if not self._display:
            raise OSError("cannot open the X display")

    def close(self) -> None:
        if self._display:
            self._x11.XCloseDisplay(self._display)
            self._display = None

    def windows_of(self, pid: int) -> list[int]:
        """Shown top-level windows whose ``_NET_WM_PID`` is ``pid`` (GLFW and Qt set it)."""
        x11, display = self._x11, self._display
        atom = x11.XInternAtom(display, b"_NET_WM_PID", 1)
        if not atom:
            return []
        root, parent = _Window(), _Window()
        children = ctypes.POINTER(_Window)()
        count = ctypes.c_uint()
        if not x11.XQueryTree(
            display, x11.XDefaultRootWindow(display), root, parent, children, count
        ):
            return []
        found = []
        try:
            for i in range(count.value):
                attributes = _WindowAttributes()
                if (
                    self._cardinal(children[i], atom) == pid
                    and x11.XGetWindowAttributes(display, children[i], attributes)
                    and attributes.map_state == _IS_VIEWABLE
                ):
                    found.append(children[i])
        finally:
            x11.XFree(children)
        return found

    def _cardinal(self, window: int, atom: int) -> int | None:
        actual_type, actual_format = _Atom(), ctypes.c_int()
        items, remaining = ctypes.c_ulong(), ctypes.c_ulong()
        data = ctypes.c_void_p()
        status = self._x11.XGetWindowProperty(
            self._display, window, atom, 0, 1, 0, 0, actual_type, actual_format, items,
            remaining, data,
        )  # fmt: skip
        if status != 0 or not data.value:
            return None
        try:
            return ctypes.cast(data, ctypes.POINTER(ctypes.c_ulong))[0] if items.value else None
        finally:
            self._x11.XFree(data)

    def press(self, window: int, key: str, hold_s: float = 0.15) -> None:
        """Focus ``window`` and press ``key`` (an X keysym name: ``space``, ``l``, ``Right``)."""
        x11 = self._x11
        keycode = x11.XKeysymToKeycode(self._display, x11.XStringToKeysym(key.encode()))
        if not keycode:
            raise ValueError(f"no key for keysym {key!r}")
        revert_to_parent = 2
        x11.XSetInputFocus(self._display, window, revert_to_parent, 0)
        self._xtst.XTestFakeKeyEvent(self._display, keycode, 1, 0)
        x11.XSync(self._display, 0)
        # Long enough for a frame loop that polls its events once per (slow) frame.
        time.sleep(hold_s)
        self._xtst.XTestFakeKeyEvent(self._display, keycode, 0, 0)
        x11.XSync(self._display, 0)
