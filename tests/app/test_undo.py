"""Undo steps of the editor's document: a gesture is one step, and its edits are freed."""

from __future__ import annotations

import gc

import pytest

from sand_editor.app._model import PresetModel, _ChangeCommand
from sand_editor.preset import Preset

pytestmark = pytest.mark.qt

PATH = "shading.uv_scale"


def live_commands() -> int:
    gc.collect()
    return sum(1 for obj in gc.get_objects() if isinstance(obj, _ChangeCommand))


def test_a_long_gesture_is_one_step_and_frees_its_edits(qapp):
    model = PresetModel()
    start = model.preset
    before = live_commands()
    changes = []
    model.changed.connect(lambda preset, paths: changes.append(paths))

    for i in range(500):
        model.edit(PATH, 10.0 + i * 0.5, gesture=True)

    assert model.undo_stack.count() == 1
    assert len(changes) == 500 and all(paths == {PATH} for paths in changes)
    # The step and at most a stray wrapper; each merged edit held two presets.
    assert live_commands() - before <= 2, live_commands() - before
    assert model.preset.get(PATH) == 10.0 + 499 * 0.5
    model.undo_stack.undo()
    assert model.preset == start
    model.undo_stack.redo()
    assert model.preset.get(PATH) == 10.0 + 499 * 0.5


def test_gestures_end_and_saved_states_stay_one_step_away(qapp):
    model = PresetModel(Preset())
    for value in (20.0, 21.0):
        model.edit(PATH, value, gesture=True)
    model.end_gesture()
    for value in (30.0, 31.0):
        model.edit(PATH, value, gesture=True)
    assert model.undo_stack.count() == 2  # two gestures, two steps
    model.undo_stack.setClean()
    model.edit(PATH, 32.0, gesture=True)  # the same gesture, past a save
    assert model.undo_stack.count() == 3
    model.undo_stack.undo()
    assert model.undo_stack.isClean() and model.preset.get(PATH) == 31.0
    model.undo_stack.undo()
    assert model.preset.get(PATH) == 21.0
    model.undo_stack.undo()
    assert model.preset == Preset()


def test_a_drag_back_to_its_start_leaves_nothing_to_undo(qapp):
    model = PresetModel(Preset())
    start = model.preset.get(PATH)
    before = live_commands()
    for value in (start + 1, start + 2, start):
        model.edit(PATH, value, gesture=True)
    assert model.undo_stack.count() == 0 and not model.undo_stack.canRedo()
    assert model.preset == Preset()
    assert live_commands() == before
