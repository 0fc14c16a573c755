"""The parameter panel, built from the FIELDS table: one labelled control per preset field."""

from __future__ import annotations

import random
from collections.abc import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QAbstractSpinBox,
    QDoubleSpinBox,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPlainTextEdit,
    QPushButton,
    QSlider,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from sand_editor.app._bindings import connect_model_to_widgets, connect_widget_to_model
from sand_editor.app._model import PresetModel
from sand_editor.app._widgets import SLIDER_STEPS, ColorSwatch, FloatScale
from sand_editor.preset import FIELDS, FieldSpec

SECTION_TITLES = {"": "Preset", "generation": "Generation", "shading": "Shading"}
# Integer ranges this short get a slider too; longer ones (seed, period) would be too coarse.
INT_SLIDER_RANGE = 64
# QSpinBox holds a C int; wider integer fields (the 32-bit seed) use a 0-decimal double box.
_QT_INT_MAX = 2**31 - 1
# One width for every number box keeps the sliders beside them aligned.
SPIN_WIDTH = 96


def _tooltip(spec: FieldSpec) -> str:
    unit = f" [{spec.unit}]" if spec.unit else ""
    return f"{spec.doc}{unit}\n{spec.path}"


def _name(spec: FieldSpec, part: str) -> str:
    return f"{spec.path}:{part}"


class ControlsPanel(QWidget):
    """Labelled controls for every field in FIELDS, grouped by section, bound to a model."""

    def __init__(self, model: PresetModel, parent: QWidget | None = None):
        super().__init__(parent)
        self._model = model
        layout = QVBoxLayout(self)
        forms: dict[str, QFormLayout] = {}
        for spec in FIELDS:
            if spec.section not in forms:
                group = QGroupBox(SECTION_TITLES.get(spec.section, spec.section.title()), self)
                forms[spec.section] = QFormLayout(group)
                forms[spec.section].setFieldGrowthPolicy(
                    QFormLayout.FieldGrowthPolicy.AllNonFixedFieldsGrow
                )
                layout.addWidget(group)
            label = QLabel(spec.label, self)
            label.setToolTip(_tooltip(spec))
            row = _ROW_BUILDERS[spec.kind](self, spec)
            row.setToolTip(_tooltip(spec))
            forms[spec.section].addRow(label, row)
        layout.addStretch(1)

    # -- one builder per field kind ------------------------------------------------------------

    def _float_row(self, spec: FieldSpec) -> QWidget:
        scale = FloatScale(spec)
        slider = QSlider(Qt.Orientation.Horizontal, objectName=_name(spec, "slider"))
        slider.setRange(0, SLIDER_STEPS)
        spin = QDoubleSpinBox(objectName=_name(spec, "spin"))
        spin.setRange(spec.minimum, spec.maximum)
        spin.setDecimals(scale.decimals)
        spin.setSingleStep((spec.maximum - spec.minimum) / 100)
        spin.setKeyboardTracking(False)
        spin.setFixedWidth(SPIN_WIDTH)
        if spec.unit:
            spin.setSuffix(f" {spec.unit}")

        def show(value: float) -> None:
            slider.setValue(scale.to_position(value))
            spin.setValue(value)

        model, path = self._model, spec.path
        sync = connect_model_to_widgets(model, path, [slider, spin], show)
        connect_widget_to_model(
            slider.valueChanged,
            model,
            path,
            lambda: scale.to_value(slider.value()),
            gesture=slider.isSliderDown,
            on_refused=sync,
        )
        slider.sliderReleased.connect(model.end_gesture)
        connect_widget_to_model(spin.valueChanged, model, path, spin.value, on_refused=sync)
        return _row(slider, spin)

    def _int_row(self, spec: FieldSpec) -> QWidget:
        minimum, maximum = int(spec.minimum), int(spec.maximum)
        if maximum > _QT_INT_MAX:
            spin: QAbstractSpinBox = QDoubleSpinBox(objectName=_name(spec, "spin"))
            spin.setDecimals(0)
        else:
            spin = QSpinBox(objectName=_name(spec, "spin"))
        spin.setRange(minimum, maximum)
        spin.setKeyboardTracking(False)
        if spec.unit:
            spin.setSuffix(f" {spec.unit}")
        widgets: list[QWidget] = [spin]
        slider = None
        if maximum - minimum <= INT_SLIDER_RANGE:
            slider = QSlider(Qt.Orientation.Horizontal, objectName=_name(spec, "slider"))
            slider.setRange(0, maximum - minimum)
            slider.setPageStep(1)
            spin.setFixedWidth(SPIN_WIDTH)
            widgets.insert(0, slider)

        def show(value: int) -> None:
            spin.setValue(value)
            if slider is not None:
                slider.setValue(value - minimum)

        model, path = self._model, spec.path
        sync = connect_model_to_widgets(model, path, widgets, show)
        connect_widget_to_model(
            spin.valueChanged, model, path, lambda: int(spin.value()), on_refused=sync
        )
        if slider is not None:
            connect_widget_to_model(
                slider.valueChanged,
                model,
                path,
                lambda: minimum + slider.value(),
                gesture=slider.isSliderDown,
                on_refused=sync,
            )
            slider.sliderReleased.connect(model.end_gesture)
        if spec.path == "generation.seed":
            randomize = QPushButton("Randomize seed", objectName="randomize-seed")
            randomize.setToolTip("Pick a random seed: a new arrangement of the same sand.")
            randomize.clicked.connect(lambda: model.edit(path, random.randint(minimum, maximum)))
            widgets.append(randomize)
        return _row(*widgets)

    def _color_row(self, spec: FieldSpec) -> QWidget:
        swatch = ColorSwatch(spec.label, _name(spec, "swatch"))
        sync = connect_model_to_widgets(self._model, spec.path, [swatch], swatch.set_color)
        connect_widget_to_model(
            swatch.picked, self._model, spec.path, lambda: swatch.color, on_refused=sync
        )
        return _row(swatch, stretch=True)

    def _colors_row(self, spec: FieldSpec) -> QWidget:
        swatches = [
            ColorSwatch(f"{spec.label} {i + 1}", _name(spec, f"swatch{i}"))
            for i in range(spec.count)
        ]

        self._bind_elements(
            spec,
            swatches,
            show_one=lambda swatch, color: swatch.set_color(color),
            changed=lambda swatch: swatch.picked,
            read_one=lambda swatch: swatch.color,
        )
        return _row(*swatches, stretch=True)

    def _weights_row(self, spec: FieldSpec) -> QWidget:
        spins = []
        for index in range(spec.count):
            spin = QDoubleSpinBox(objectName=_name(spec, f"spin{index}"))
            spin.setRange(spec.minimum, spec.maximum)
            spin.setDecimals(1)
            spin.setKeyboardTracking(False)
            spin.setButtonSymbols(QAbstractSpinBox.ButtonSymbols.NoButtons)
            spins.append(spin)

        self._bind_elements(
            spec,
            spins,
            show_one=lambda spin, weight: spin.setValue(weight),
            changed=lambda spin: spin.valueChanged,
            read_one=lambda spin: spin.value(),
        )
        return _row(*spins)

    def _bind_elements(self, spec: FieldSpec, widgets, show_one, changed, read_one) -> None:
        """Bind one widget per element of a tuple field (the four colours, the four weights)."""

        def show(values) -> None:
            for widget, value in zip(widgets, values, strict=True):
                show_one(widget, value)

        sync = connect_model_to_widgets(self._model, spec.path, widgets, show)
        for index, widget in enumerate(widgets):
            connect_widget_to_model(
                changed(widget),
                self._model,
                spec.path,
                self._element_reader(spec.path, index, lambda w=widget: read_one(w)),
                on_refused=sync,
            )

    def _text_row(self, spec: FieldSpec) -> QWidget:
        if spec.multiline:
            edit = QPlainTextEdit(objectName=_name(spec, "text"))
            edit.setMaximumHeight(72)
            edit.setTabChangesFocus(True)

            def show(text: str) -> None:
                # Re-setting identical text would move the cursor while the user types.
                if edit.toPlainText() != text:
                    edit.setPlainText(text)

            sync = connect_model_to_widgets(self._model, spec.path, [edit], show)
            connect_widget_to_model(
                edit.textChanged,
                self._model,
                spec.path,
                edit.toPlainText,
                gesture=lambda: True,
                on_refused=sync,
            )
            return edit
        line = QLineEdit(objectName=_name(spec, "text"))
        line.setMaxLength(int(spec.maximum))
        sync = connect_model_to_widgets(self._model, spec.path, [line], line.setText)
        connect_widget_to_model(
            line.editingFinished, self._model, spec.path, line.text, on_refused=sync
        )
        return line

    def _element_reader(self, path: str, index: int, read: Callable[[], object]):
        def read_list() -> tuple:
            values = list(self._model.preset.get(path))
            values[index] = read()
            return tuple(values)

        return read_list


_ROW_BUILDERS: dict[str, Callable[[ControlsPanel, FieldSpec], QWidget]] = {
    "float": ControlsPanel._float_row,
    "int": ControlsPanel._int_row,
    "color": ControlsPanel._color_row,
    "colors": ControlsPanel._colors_row,
    "weights": ControlsPanel._weights_row,
    "text": ControlsPanel._text_row,
}


def _row(*widgets: QWidget, stretch: bool = False) -> QWidget:
    row = QWidget()
    layout = QHBoxLayout(row)
    layout.setContentsMargins(0, 0, 0, 0)
    for widget in widgets:
        layout.addWidget(widget, 1 if isinstance(widget, QSlider) else 0)
    if stretch:
        layout.addStretch(1)
    return row
