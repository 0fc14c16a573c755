"""The two helpers that bind a widget to a preset field, one per direction.

Model → widget updates block the widget's signals, so they never echo back as an edit.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from PySide6.QtCore import QObject, SignalInstance

from sand_editor.app._model import PresetModel


def connect_model_to_widgets(
    model: PresetModel,
    path: str,
    widgets: Sequence[QObject],
    show: Callable[[Any], None],
) -> Callable[..., None]:
    """Call ``show(value)`` now and whenever the field at ``path`` changes.

    Returns the update function; calling it with no arguments re-shows the model's value
    (used to undo a refused edit in the widget).
    """

    def update(_preset=None, paths: frozenset[str] | None = None) -> None:
        if paths is not None and path not in paths:
            return
        previous = [widget.blockSignals(True) for widget in widgets]
        try:
            show(model.preset.get(path))
        finally:
            for widget, was_blocked in zip(widgets, previous, strict=True):
                widget.blockSignals(was_blocked)

    model.changed.connect(update)
    update()
    return update


def connect_widget_to_model(
    signal: SignalInstance,
    model: PresetModel,
    path: str,
    read: Callable[[], Any],
    *,
    gesture: Callable[[], bool] = lambda: False,
    on_refused: Callable[[], None] | None = None,
) -> None:
    """When ``signal`` fires, write ``read()`` into the field at ``path``.

    ``gesture()`` says whether the edit continues a gesture (merged into one undo step);
    ``on_refused`` runs when the model rejects the value.
    """

    def write(*_args: Any) -> None:
        if not model.edit(path, read(), gesture=gesture()) and on_refused is not None:
            on_refused()

    signal.connect(write)
