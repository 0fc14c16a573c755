"""The editor's document: the current preset, its change signal and its undo history."""

from __future__ import annotations

from typing import Any

from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QUndoCommand, QUndoStack

from sand_editor.preset import FIELDS, Preset, PresetError, field_spec

# Any value shared by all mergeable commands; mergeWith decides whether two really belong together.
_MERGE_ID = 1


def changed_paths(old: Preset, new: Preset) -> frozenset[str]:
    """Dotted paths of the fields whose values differ between two presets."""
    return frozenset(spec.path for spec in FIELDS if old.get(spec.path) != new.get(spec.path))


class PresetModel(QObject):
    """Holds the preset being edited; every change goes through here and is announced once.

    Signals
    -------
    changed(Preset, frozenset[str])
        The new preset and the paths of the fields that changed (never empty).
    refused(str)
        An edit was not applied because the value is not acceptable; the message says why.
    """

    changed = Signal(object, object)
    refused = Signal(str)

    def __init__(self, preset: Preset | None = None, parent: QObject | None = None):
        super().__init__(parent)
        self._preset = preset if preset is not None else Preset()
        self.undo_stack = QUndoStack(self)
        # Edits within one gesture (a slider drag, typing) share a serial and merge into one
        # undo step; ending the gesture starts a new serial.
        self._gesture_serial = 0

    @property
    def preset(self) -> Preset:
        return self._preset

    def reset(self, preset: Preset) -> None:
        """Start a new document (New, Open, Revert): no undo history, nothing modified."""
        self.undo_stack.clear()
        self._apply(preset)
        self.undo_stack.setClean()

    def set_preset(self, preset: Preset, text: str = "Change preset") -> None:
        """Replace the whole preset as one undoable step."""
        if preset != self._preset:
            self.undo_stack.push(_ChangeCommand(self, self._preset, preset, text, None))

    def edit(self, path: str, value: Any, *, gesture: bool = False) -> bool:
        """Set one field as an undoable step; return False (and emit ``refused``) if invalid.

        With ``gesture`` true, consecutive edits of the same field merge into one undo step
        until :meth:`end_gesture`.
        """
        try:
            preset = self._preset.replace(**{path: value})
        except PresetError as error:
            self.refused.emit(str(error))
            return False
        if preset != self._preset:
            merge_key = (path, self._gesture_serial) if gesture else None
            text = f"Change {field_spec(path).label}"
            self.undo_stack.push(_ChangeCommand(self, self._preset, preset, text, merge_key))
        return True

    def end_gesture(self) -> None:
        self._gesture_serial += 1

    def _apply(self, preset: Preset) -> None:
        paths = changed_paths(self._preset, preset)
        self._preset = preset
        if paths:
            self.changed.emit(preset, paths)


class _ChangeCommand(QUndoCommand):
    def __init__(self, model: PresetModel, old: Preset, new: Preset, text: str, merge_key):
        super().__init__(text)
        self._model = model
        self._old = old
        self._new = new
        self._merge_key = merge_key

    def id(self) -> int:
        return _MERGE_ID if self._merge_key is not None else -1

    def mergeWith(self, other: QUndoCommand) -> bool:
        if not isinstance(other, _ChangeCommand) or other._merge_key != self._merge_key:
            return False
        self._new = other._new
        # A drag that ends where it started leaves nothing to undo.
        self.setObsolete(self._new == self._old)
        return True

    def redo(self) -> None:
        self._model._apply(self._new)

    def undo(self) -> None:
        self._model._apply(self._old)
