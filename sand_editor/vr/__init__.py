"""The VR viewer: the editor's scene in OpenXR stereo, or in a desktop stereo preview.

Qt-free, on top of ``sand_editor.render``. ``link`` (the editor ↔ viewer protocol) imports
neither OpenXR nor OpenGL, so the editor can use it; ``xr_backend`` (with ``xr_swapchains`` and
``xr_input``) is the only code that imports OpenXR; ``loop`` is the frame loop both backends share.
"""
