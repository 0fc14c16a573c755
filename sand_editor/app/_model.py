"""The editor's document: the current preset, its change signal and its undo history."""

from __future__ import annotations

from typing import Any

from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QUndoCommand, QUndoStack

from sand_editor.preset import FIELDS, Preset, PresetError, field_spec


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
            self._push(_ChangeCommand(self, self._preset, preset, text, merge_key))
        return True

    def _push(self, command: _ChangeCommand) -> None:
        """Push ``command``, or fold it into the last step when both belong to one gesture.

        The folding is done here, not by ``QUndoCommand.mergeWith``: Qt deletes a merged
        command inside ``push``, before PySide hands the command's ownership to the stack, so
        the stack would keep every merged command's Python object (and its two presets) for
        as long as it lives.
        """
        stack = self.undo_stack
        index = stack.index()
        top = stack.command(index - 1) if index > 0 else None
        if (
            command.merge_key is not None
            and isinstance(top, _ChangeCommand)
            and top.merge_key == command.merge_key
            and index == stack.count()  # nothing to redo: the last step is the newest
            and index != stack.cleanIndex()  # a saved state stays one undo step away
        ):
            top.new = command.new
            self._apply(top.new)
            if top.new == top.old:
                # A drag that ends where it started leaves nothing to undo; the stack drops
                # an obsolete command when it is undone (a no-op here).
                top.setObsolete(True)
                stack.undo()
            return
        stack.push(command)

    def end_gesture(self) -> None:
        self._gesture_serial += 1

    def _apply(self, preset: Preset) -> None:
        paths = changed_paths(self._preset, preset)
        self._preset = preset
        if paths:
            self.changed.emit(preset, paths)


class _ChangeCommand(QUndoCommand):
    """One undo step from ``old`` to ``new``; steps of one gesture share a ``merge_key``."""

    def __init__(self, model: PresetModel, old: Preset, new: Preset, text: str, merge_key):
        super().__init__(text)
        self._model = model
        self.old = old
        self.new = new
        self.merge_key = merge_key

    def redo(self) -> None:
        self._model._apply(self.new)

    def undo(self) -> None:
        self._model._apply(self.old)
