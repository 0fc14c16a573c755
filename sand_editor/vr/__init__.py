"""The VR viewer: the editor's scene in OpenXR stereo, or in a desktop stereo preview.

Qt-free, on top of ``sand_editor.render``. ``link`` (the editor ↔ viewer protocol) imports
neither OpenXR nor OpenGL, so the editor can use it; ``xr_backend`` (with ``xr_swapchains`` and
``xr_input``) is the only code that imports OpenXR; ``loop`` is the frame loop both backends share.
"""

__all__ = ["resident_mb"]


def __getattr__(name: str):
    # Imported only when asked for, so that importing ``link`` loads no OpenGL.
    if name == "resident_mb":
        from sand_editor.vr._resources import resident_mb

        return resident_mb
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
