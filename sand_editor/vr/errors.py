"""Why the viewer could not start, each with its exit status (``sand_editor.vr.link``)."""

from __future__ import annotations

from sand_editor.vr.link import EXIT_GRAPHICS, EXIT_LINK_BROKEN, EXIT_NO_HEADSET, EXIT_NO_RUNTIME

RUNTIME_HELP = (
    "Install and activate an OpenXR runtime such as SteamVR, Monado or WiVRn (it sets the "
    "active runtime, /etc/xdg/openxr/1/active_runtime.json or ~/.config/openxr/1/"
    "active_runtime.json; XR_RUNTIME_JSON overrides it), or use the desktop preview: "
    "sand-editor vr --desktop"
)


class ViewerError(RuntimeError):
    """A failure the user can act on; ``status`` is the exit status."""

    status = EXIT_GRAPHICS


class NoRuntimeError(ViewerError):
    status = EXIT_NO_RUNTIME


class NoHeadsetError(ViewerError):
    status = EXIT_NO_HEADSET


class GraphicsError(ViewerError):
    status = EXIT_GRAPHICS


class LinkBrokenError(ViewerError):
    """Reading the editor's link failed (EOF is no failure: it means quit)."""

    status = EXIT_LINK_BROKEN
