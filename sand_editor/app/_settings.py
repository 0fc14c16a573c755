"""What the editor remembers between sessions (QSettings): recent files, window layout, the last
preview tab and the 3D view's camera, clock and mode."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QByteArray, QSettings

SCHEMA_VERSION = 1
MAX_RECENT = 8
# The 3D view's settings and their types (QSettings hands INI values back as strings).
VIEW3D_FIELDS = {
    "distance_m": float,
    "pitch_deg": float,
    "heading_deg": float,
    "time_hours": float,
    "mode": str,
    "show_sphere": bool,
    "day_speed": int,
}


def _as_bool(value) -> bool:
    return value if isinstance(value, bool) else str(value).lower() in {"true", "1"}


def migrate(settings: QSettings) -> None:
    """Bring stored settings to ``SCHEMA_VERSION``; settings from a newer editor are dropped,
    since their meaning cannot be known."""
    version = int(settings.value("schema_version", SCHEMA_VERSION))
    if version > SCHEMA_VERSION:
        settings.clear()
    settings.setValue("schema_version", SCHEMA_VERSION)


class EditorSettings:
    """Typed access to the editor's QSettings."""

    def __init__(self, settings: QSettings | None = None) -> None:
        self.store = settings if settings is not None else QSettings()
        migrate(self.store)

    # -- recent files ----------------------------------------------------------------------------

    def recent_files(self) -> list[Path]:
        """Most recent first; files that no longer exist are left out."""
        value = self.store.value("recent_files", [])
        names = [value] if isinstance(value, str) else list(value or [])
        return [Path(name) for name in names if Path(name).is_file()]

    def add_recent(self, path: Path) -> None:
        path = Path(path).resolve()
        names = [str(path)] + [str(p) for p in self.recent_files() if p.resolve() != path]
        self.store.setValue("recent_files", names[:MAX_RECENT])

    def clear_recent(self) -> None:
        self.store.setValue("recent_files", [])

    # -- layout ----------------------------------------------------------------------------------

    def layout(self) -> dict[str, QByteArray | int | None]:
        """Saved window geometry and state, splitter state, preview tab (None where unsaved)."""
        tab = self.store.value("window/tab")
        return {
            "geometry": self.store.value("window/geometry"),
            "state": self.store.value("window/state"),
            "splitter": self.store.value("window/splitter"),
            "tab": int(tab) if tab is not None else None,
        }

    def save_layout(self, geometry, state, splitter, tab: int) -> None:
        self.store.setValue("window/geometry", geometry)
        self.store.setValue("window/state", state)
        self.store.setValue("window/splitter", splitter)
        self.store.setValue("window/tab", int(tab))

    # -- the 3D view -----------------------------------------------------------------------------

    def view3d(self) -> dict:
        """The saved 3D view settings that are present and readable."""
        saved = {}
        for name, kind in VIEW3D_FIELDS.items():
            value = self.store.value(f"view3d/{name}")
            if value is None:
                continue
            try:
                saved[name] = _as_bool(value) if kind is bool else kind(value)
            except (TypeError, ValueError):
                continue  # an unreadable value keeps the default
        return saved

    def save_view3d(self, values: dict) -> None:
        for name in VIEW3D_FIELDS:
            if name in values:
                self.store.setValue(f"view3d/{name}", values[name])

    def sync(self) -> None:
        self.store.sync()
