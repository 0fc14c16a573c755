"""Small widgets the parameter panel needs that Qt lacks: a colour swatch and a slider scale
for float ranges."""

from __future__ import annotations

import math

from PySide6.QtCore import Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QColorDialog, QPushButton, QWidget

from sand_editor.preset import Color, FieldSpec

SLIDER_STEPS = 1000


class ColorSwatch(QPushButton):
    """A button filled with a colour; clicking it opens a colour dialog.

    ``picked(Color)`` is emitted when the user chooses a different colour.
    """

    picked = Signal(object)

    def __init__(self, title: str, object_name: str, parent: QWidget | None = None):
        super().__init__(parent, objectName=object_name)
        self._title = title
        self._color = Color(0, 0, 0)
        self.setFixedSize(36, 22)
        self.clicked.connect(self._choose)

    @property
    def color(self) -> Color:
        return self._color

    def set_color(self, color: Color) -> None:
        self._color = color
        self.setStyleSheet(f"background-color: {color.hex}; border: 1px solid #555;")
        self.setAccessibleDescription(color.hex)

    def _choose(self) -> None:
        chosen = QColorDialog.getColor(QColor(self._color.hex), self, self._title)
        if chosen.isValid():
            color = Color(chosen.red(), chosen.green(), chosen.blue())
            if color != self._color:
                self.set_color(color)
                self.picked.emit(color)


class FloatScale:
    """Maps a float field onto integer slider positions 0…SLIDER_STEPS.

    Ranges spanning three decades or more above zero (shininess, texture scale) map
    logarithmically, so the slider is usable at both ends.
    """

    def __init__(self, spec: FieldSpec):
        self.minimum = float(spec.minimum)
        self.maximum = float(spec.maximum)
        self.logarithmic = self.minimum > 0 and self.maximum / self.minimum >= 1000
        step = (self.maximum - self.minimum) / SLIDER_STEPS
        # Enough decimals for one slider step and for the range's lower end.
        wanted = max(
            -math.floor(math.log10(step)) + 1, -math.floor(math.log10(abs(self.minimum) or 1))
        )
        self.decimals = min(max(wanted, 3), 6)

    def _ends(self) -> tuple[float, float]:
        if self.logarithmic:
            return math.log(self.minimum), math.log(self.maximum)
        return self.minimum, self.maximum

    def to_position(self, value: float) -> int:
        low, high = self._ends()
        x = math.log(max(value, self.minimum)) if self.logarithmic else value
        return round((x - low) / (high - low) * SLIDER_STEPS)

    def to_value(self, position: int) -> float:
        low, high = self._ends()
        x = low + (high - low) * position / SLIDER_STEPS
        value = math.exp(x) if self.logarithmic else x
        return min(max(round(value, self.decimals), self.minimum), self.maximum)
