"""Open, save, revert, undo and redo, and the questions about unsaved changes."""

from __future__ import annotations

import pytest
from PySide6.QtWidgets import QMessageBox, QSlider

from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

pytestmark = pytest.mark.qt


@pytest.fixture
def critical_calls(monkeypatch):
    """Texts of the error boxes the window shows, answered at once instead of shown."""
    calls = []

    def record(parent, title, text, *args, **kwargs):
        calls.append(text)
        return QMessageBox.StandardButton.Ok

    monkeypatch.setattr(QMessageBox, "critical", record)
    return calls


def answer_questions(monkeypatch, answer):
    asked = []

    def reply(parent, title, text, *args, **kwargs):
        asked.append(text)
        return answer

    monkeypatch.setattr(QMessageBox, "question", reply)
    return asked


def test_failed_open_shows_the_error_and_keeps_the_current_work(window, tmp_path, critical_calls):
    window.model.edit("generation.threshold", 0.45)
    work = window.model.preset
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "sand-editor-preset", ', encoding="utf-8")

    assert not window.open_path(broken)

    assert len(critical_calls) == 1
    assert str(broken) in critical_calls[0] and "not valid JSON" in critical_calls[0]
    assert window.model.preset == work
    assert window.isWindowModified()
    assert window.model.undo_stack.canUndo()


def test_open_replaces_the_preset_and_clears_history(window, tmp_path):
    path = tmp_path / "coarse.json"
    Preset(name="coarse").replace(**{"generation.period": 12}).save(path)
    window.model.edit("shading.sss", 1.0)

    assert window.open_path(path)

    assert window.model.preset == Preset.load(path)
    assert window.controls.findChild(object, "generation.period:spin").value() == 12
    assert window.windowTitle() == f"coarse — {path}[*]"
    assert not window.isWindowModified()
    assert not window.model.undo_stack.canUndo()


def test_save_writes_a_file_that_loads_back_equal(window, tmp_path):
    window.model.edit("generation.roundness", 0.6)
    window.model.edit("shading.clear_grains", 0.4)
    assert window.isWindowModified()
    path = tmp_path / "mine.json"

    assert window.save_to(path)

    assert Preset.load(path) == window.model.preset
    assert not window.isWindowModified()
    assert window.path == path
    assert window.windowTitle() == f"paper-default — {path}[*]"

    window.model.edit("generation.roundness", 0.7)
    assert window.save()  # Save now goes to the same file without asking
    assert Preset.load(path).generation.roundness == 0.7


def test_bundled_preset_is_a_template_that_save_never_overwrites(window, monkeypatch, tmp_path):
    assert window.path is None
    target = tmp_path / "copy.json"
    monkeypatch.setattr(
        "sand_editor.app._window.QFileDialog.getSaveFileName",
        lambda *args, **kwargs: (str(tmp_path / "copy"), ""),
    )
    original = bundled_preset("paper-default").read_bytes()
    window.model.edit("generation.jitter", 0.5)

    assert window.save()

    assert bundled_preset("paper-default").read_bytes() == original
    assert Preset.load(target).generation.jitter == 0.5


def test_undo_restores_and_redo_reapplies(window):
    original = window.model.preset.generation.threshold
    spin = window.controls.findChild(object, "generation.threshold:spin")
    spin.setValue(0.5)
    assert window.isWindowModified()

    window.undo_action.trigger()
    assert window.model.preset.generation.threshold == original
    assert spin.value() == original
    assert not window.isWindowModified()

    window.redo_action.trigger()
    assert window.model.preset.generation.threshold == 0.5
    assert spin.value() == 0.5


def test_a_slider_drag_is_one_undo_step(window):
    slider = window.controls.findChild(QSlider, "generation.roundness:slider")
    original = window.model.preset.generation.roundness
    stack = window.model.undo_stack

    slider.setSliderDown(True)
    for position in (300, 350, 420, 500):
        slider.setValue(position)
    slider.setSliderDown(False)

    assert window.model.preset.generation.roundness == 0.5
    assert stack.count() == 1
    slider.setSliderDown(True)
    slider.setValue(600)
    slider.setSliderDown(False)
    assert stack.count() == 2  # a second drag is a second step

    stack.undo()
    assert window.model.preset.generation.roundness == 0.5
    stack.undo()
    assert window.model.preset.generation.roundness == original


def test_revert_reloads_the_file(window, monkeypatch):
    answer_questions(monkeypatch, QMessageBox.StandardButton.Discard)
    window.model.edit("generation.layers", 3)

    window.revert_action.trigger()

    assert window.model.preset == Preset.load(bundled_preset("paper-default"))
    assert not window.isWindowModified()


def test_new_starts_from_the_defaults(window):
    window.new_preset()
    assert window.model.preset == Preset()
    assert window.path is None


def test_closing_with_unsaved_changes_asks_and_cancel_keeps_the_window(window, monkeypatch):
    window.model.edit("shading.sss", 2.0)
    asked = answer_questions(monkeypatch, QMessageBox.StandardButton.Cancel)

    assert not window.close()
    assert window.isVisible()
    assert len(asked) == 1 and "unsaved changes" in asked[0]

    answer_questions(monkeypatch, QMessageBox.StandardButton.Discard)
    assert window.close()


def test_closing_without_changes_does_not_ask(window, monkeypatch):
    asked = answer_questions(monkeypatch, QMessageBox.StandardButton.Cancel)
    assert window.close()
    assert asked == []


def test_window_wears_the_shipped_stylesheet(window):
    from sand_editor.resources import ui_dir

    shipped = (ui_dir() / "editor.qss").read_text(encoding="utf-8")
    assert window.styleSheet() == shipped
    assert "QGroupBox" in shipped


HOSTILE_FILES = {
    "digits": '{"format": "sand-editor-preset", "schema_version": 2, "seed": 1' + "0" * 4400 + "}",
    "nesting": '{"format": "sand-editor-preset", "schema_version": 2, "name": '
    + "[" * 980
    + "]" * 980
    + "}",
    "mislabelled": '{"format": "sand-editor-preset", "schema_version": 1, "generation": {}}',
    "control key": '{"format": "sand-editor-preset", "schema_version": 2, "a\\nb\\u001b": 1}',
}


@pytest.mark.parametrize("kind", list(HOSTILE_FILES))
def test_hostile_files_get_one_line_dialog_and_the_work_stays(
    window, tmp_path, critical_calls, kind
):
    window.model.edit("generation.threshold", 0.45)
    work = window.model.preset
    path = tmp_path / f"{kind}.json"
    path.write_text(HOSTILE_FILES[kind], encoding="utf-8")
    assert not window.open_path(path)
    assert len(critical_calls) == 1
    message = critical_calls[0]
    assert str(path) in message
    assert window.model.preset == work and window.isWindowModified()


@pytest.mark.parametrize("name", ["../../x", "/tmp/x", "CON"])
def test_save_dialogs_offer_a_file_in_the_folder_whatever_the_name(window, tmp_path, name):
    from dataclasses import replace
    from pathlib import Path

    window.model.reset(replace(Preset(), name=name))
    for suffix in (".json", ".glb", ".png"):
        offered = Path(window.suggested_file(tmp_path, suffix))
        assert offered.parent == tmp_path and offered.suffix == suffix
        assert not offered.name.startswith((".", "CON."))
