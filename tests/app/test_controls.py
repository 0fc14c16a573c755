"""The parameter panel follows the model, and edits the model, one change at a time."""

from __future__ import annotations

import pytest
from PySide6.QtWidgets import QDoubleSpinBox, QLabel, QPushButton, QSlider, QSpinBox, QWidget

from sand_editor.preset import FIELDS

pytestmark = pytest.mark.qt


def control(window, path: str, part: str, kind=QWidget):
    widget = window.controls.findChild(kind, f"{path}:{part}")
    assert widget is not None, f"no {part} control for {path}"
    return widget


def test_every_field_has_a_control_with_its_doc_as_tooltip(window):
    for spec in FIELDS:
        named = [
            w
            for w in window.controls.findChildren(QWidget)
            if w.objectName().startswith(spec.path + ":")
        ]
        assert named, f"no control for {spec.path}"
        labels = [w for w in window.controls.findChildren(QLabel) if w.text() == spec.label]
        assert labels and spec.doc in labels[0].toolTip()


def test_model_change_shows_in_slider_and_spin_box(window, model_signals):
    window.model.set_preset(window.model.preset.replace(**{"generation.threshold": 0.4}))

    assert control(window, "generation.threshold", "spin", QDoubleSpinBox).value() == 0.4
    assert control(window, "generation.threshold", "slider", QSlider).value() == 400
    assert len(model_signals) == 1
    assert model_signals[0][1] == frozenset({"generation.threshold"})


def test_slider_edits_the_model_once_and_moves_the_spin_box(window, model_signals):
    control(window, "generation.threshold", "slider", QSlider).setValue(700)

    assert window.model.preset.generation.threshold == pytest.approx(0.7)
    assert control(window, "generation.threshold", "spin", QDoubleSpinBox).value() == 0.7
    assert [paths for _, paths in model_signals] == [frozenset({"generation.threshold"})]


def test_spin_box_edits_the_model_once_and_moves_the_slider(window, model_signals):
    control(window, "shading.sss", "spin", QDoubleSpinBox).setValue(2.5)

    assert window.model.preset.shading.sss == 2.5
    assert control(window, "shading.sss", "slider", QSlider).value() == 250
    assert len(model_signals) == 1


def test_wide_ranges_slide_logarithmically_and_reach_both_ends(window):
    slider = control(window, "shading.uv_scale", "slider", QSlider)
    slider.setValue(slider.maximum())
    assert window.model.preset.shading.uv_scale == 10000.0
    slider.setValue(slider.maximum() // 2)
    # Halfway on a log scale from 0.01 to 10000 is 10, not 5000.
    assert window.model.preset.shading.uv_scale == pytest.approx(10.0)
    slider.setValue(0)
    assert window.model.preset.shading.uv_scale == 0.01


def test_integer_controls_move_together(window):
    slider = control(window, "generation.layers", "slider", QSlider)
    spin = control(window, "generation.layers", "spin", QSpinBox)
    slider.setValue(3)
    assert window.model.preset.generation.layers == 3
    assert spin.value() == 3
    spin.stepBy(1)
    assert window.model.preset.generation.layers == 4
    assert slider.value() == 4


def test_a_refused_edit_leaves_model_and_widget_unchanged(window):
    window.model.set_preset(window.model.preset.replace(**{"generation.weights": (0, 0, 0, 4)}))
    last = control(window, "generation.weights", "spin3", QDoubleSpinBox)

    last.setValue(0)  # all weights zero is not a valid preset

    assert window.model.preset.generation.weights == (0, 0, 0, 4)
    assert last.value() == 4
    assert "all weights are 0" in window.statusBar().currentMessage()


def test_weight_spin_box_changes_one_element(window):
    control(window, "generation.weights", "spin1", QDoubleSpinBox).setValue(30)
    assert window.model.preset.generation.weights == (22, 30, 56, 4)


def test_seed_beyond_int32_is_shown_and_randomize_changes_it(window):
    window.model.edit("generation.seed", 2**32 - 1)
    spin = control(window, "generation.seed", "spin", QDoubleSpinBox)
    assert int(spin.value()) == 2**32 - 1

    window.controls.findChild(QPushButton, "randomize-seed").click()

    assert window.model.preset.generation.seed != 2**32 - 1
    assert int(spin.value()) == window.model.preset.generation.seed


def test_name_edit_renames_the_preset_and_the_window(window, qtbot):
    line = control(window, "name", "text")
    line.setText("wet beach")
    line.editingFinished.emit()

    assert window.model.preset.name == "wet beach"
    assert window.windowTitle().startswith("wet beach — ")
    assert window.isWindowModified()
