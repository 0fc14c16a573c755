"""What the editor remembers between sessions (QSettings): recent files, window layout, the last
preview tab and the 3D view's camera, clock and mode."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from PySide6.QtCore import QByteArray, QSettings

from sand_editor.view import ViewState

SCHEMA_VERSION = 2
MAX_RECENT = 8
# The 3D view's settings: the view model's fields and their types (QSettings hands INI values
# back as strings); exposure None (automatic) is stored as an absent key.
VIEW3D_FIELDS = {
    field.name: {"float": float, "bool": bool, "str": str}.get(field.type, float)
    for field in dataclasses.fields(ViewState)
}


def _as_bool(value) -> bool:
    return value if isinstance(value, bool) else str(value).lower() in {"true", "1"}


def _v1_to_v2(settings: QSettings) -> None:
    """Schema 1 kept the clock as ``time_hours`` and ``day_speed`` in simulated seconds per real
    second (0: paused); schema 2 has the view model's ``hours``, ``day_speed`` in hours per
    second and ``playing``."""
    hours = settings.value("view3d/time_hours")
    if hours is not None:
        settings.setValue("view3d/hours", hours)
        settings.remove("view3d/time_hours")
    speed = settings.value("view3d/day_speed")
    if speed is not None:
        try:
            seconds_per_second = float(speed)
        except (TypeError, ValueError):
            seconds_per_second = 0.0
        settings.setValue("view3d/playing", seconds_per_second > 0)
        if seconds_per_second > 0:
            settings.setValue("view3d/day_speed", seconds_per_second / 3600.0)
        else:
            settings.remove("view3d/day_speed")


def migrate(settings: QSettings) -> None:
    """Bring stored settings to ``SCHEMA_VERSION``; settings from a newer editor are dropped,
    since their meaning cannot be known."""
    try:
        version = int(settings.value("schema_version", SCHEMA_VERSION))
    except (TypeError, ValueError):
        version = SCHEMA_VERSION + 1  # unreadable: as unknown as a newer editor's
    if version > SCHEMA_VERSION:
        settings.clear()
    elif version < 2:
        _v1_to_v2(settings)
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

    def view3d(self) -> ViewState:
        """The saved view: fields absent or unreadable keep their defaults."""
        saved = {}
        for name, kind in VIEW3D_FIELDS.items():
            value = self.store.value(f"view3d/{name}")
            if value is None:
                continue
            try:
                saved[name] = _as_bool(value) if kind is bool else kind(value)
            except (TypeError, ValueError):
                continue  # an unreadable value keeps the default
        return ViewState.from_dict(saved)

    def save_view3d(self, state: ViewState) -> None:
        for name, value in state.to_dict().items():
            if value is None:
                self.store.remove(f"view3d/{name}")
            else:
                self.store.setValue(f"view3d/{name}", value)

    def sync(self) -> None:
        self.store.sync()
