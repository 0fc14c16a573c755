"""``run_editor``: start Qt and the editor window, or explain why it cannot start."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path

from sand_editor.preset import Preset, PresetError
from sand_editor.resources import bundled_preset, presets_dir

DEFAULT_PRESET = "paper-default"
# Qt platform plugins that draw without a window system, so they need no DISPLAY.
_DISPLAYLESS_PLATFORMS = frozenset(
    {"offscreen", "minimal", "minimalegl", "eglfs", "linuxfb", "vnc", "vkkhrdisplay"}
)
NO_DISPLAY_HINT = (
    "the editor needs a desktop session. Headless commands: sand-editor bake, sand-editor render, "
    "sand-editor bench"
)


def missing_display(environ: Mapping[str, str] = os.environ, platform: str = sys.platform):
    """Why Qt would find no display, or None when it can start.

    Qt aborts the whole process when the xcb plugin finds no X server, so this is checked
    before a QApplication exists.
    """
    if not platform.startswith("linux"):
        return None
    requested = environ.get("QT_QPA_PLATFORM", "")
    # The variable may list fallbacks ("wayland;xcb") and options ("vnc:size=800x600").
    names = {entry.partition(":")[0].strip() for entry in requested.split(";")}
    if names & _DISPLAYLESS_PLATFORMS:
        return None
    if environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"):
        return None
    return "neither DISPLAY nor WAYLAND_DISPLAY is set"


def require_display() -> None:
    """Raise ValueError (the command's one-line error) when Qt would find no display; every
    command that drives Qt without a window of its own to fall back on (the Qt benchmarks)
    calls this before it makes a QApplication, which would abort the process."""
    problem = missing_display()
    if problem is not None:
        raise ValueError(f"no display found ({problem}); run it under xvfb-run. {NO_DISPLAY_HINT}")


def run_editor(
    preset_path: str | Path | None = None,
    screenshot: str | Path | None = None,
    tab: str = "albedo",
) -> int:
    """Open the editor on a preset file (default: the bundled ``paper-default``).

    With ``screenshot``, show ``tab`` (albedo, normals, glint, layers or 3d), wait until it is
    completely drawn, save the window to that PNG file and quit; the window then uses no
    remembered settings and remembers none.

    Returns the exit code: 0 after a normal quit (or a saved screenshot), 1 when the preset
    cannot be loaded or the screenshot not taken, 2 when there is no display.
    """
    problem = missing_display()
    if problem is not None:
        print(f"sand-editor: no display found ({problem}); {NO_DISPLAY_HINT}", file=sys.stderr)
        return 2
    path = bundled_preset(DEFAULT_PRESET) if preset_path is None else Path(preset_path)
    # Shipped presets open as templates, so Save never overwrites the installed file.
    bundled = path.resolve().parent == presets_dir().resolve()
    try:
        preset = Preset.load(path)
    except PresetError as error:
        print(f"sand-editor: {error}", file=sys.stderr)
        return 1

    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from sand_editor.app._screenshot import TABS, ScreenshotWhenReady
    from sand_editor.app._window import EditorWindow

    if screenshot is not None and tab not in TABS:
        print(f"sand-editor: unknown tab {tab!r}; allowed: {', '.join(TABS)}", file=sys.stderr)
        return 1
    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName("Sand Editor")
    app.setOrganizationName("sand-editor")
    settings = QSettings() if screenshot is None else None
    window = EditorWindow(preset, path=None if bundled else path, source=path, settings=settings)
    if screenshot is not None:
        ScreenshotWhenReady(window, Path(screenshot), tab)
    window.show()
    return app.exec()
