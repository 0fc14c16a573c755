"""The window's file features: recent files, drops, baking with cancel, screenshots, remembered
layout and settings, shortcuts in tooltips."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from PySide6.QtCore import QMimeData, QPointF, QSettings, Qt, QUrl
from PySide6.QtGui import QDragEnterEvent, QDropEvent
from PySide6.QtWidgets import QApplication, QPushButton

from sand_editor.app import EditorWindow
from sand_editor.app._settings import SCHEMA_VERSION, EditorSettings
from sand_editor.bake import FILES
from sand_editor.files import OutputError
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset
from tests.app.conftest import run_python, show_and_wait_for_tile
from tests.app.test_view3d import TIMEOUT_MS, open_3d
from tests.export.test_gltf import glb_json

pytestmark = pytest.mark.qt


@pytest.fixture
def settings_file(tmp_path) -> Path:
    return tmp_path / "config" / "sand-editor.ini"


def make_window(qtbot, settings_file: Path, preset: Preset | None = None) -> EditorWindow:
    settings = QSettings(str(settings_file), QSettings.Format.IniFormat)
    window = EditorWindow(preset or Preset(), settings=settings)
    qtbot.addWidget(window, before_close_func=lambda w: w.model.undo_stack.setClean())
    show_and_wait_for_tile(window, qtbot)
    return window


def preset_file(folder: Path, name: str, seed: int) -> Path:
    path = folder / f"{name}.json"
    Preset(name=name).replace(**{"generation.seed": seed}).save(path)
    return path


def close(window: EditorWindow, qtbot) -> None:
    window.model.undo_stack.setClean()
    window.close()


# -- recent files --------------------------------------------------------------------------------


def test_opened_and_saved_files_are_listed_most_recent_first(qtbot, settings_file, tmp_path):
    first = preset_file(tmp_path, "first", 1)
    second = preset_file(tmp_path, "second", 2)
    window = make_window(qtbot, settings_file)
    assert not window.recent_menu.isEnabled()

    assert window.open_path(first)
    assert window.open_path(second)
    saved = tmp_path / "saved.json"
    assert window.save_to(saved)
    assert window.open_path(first)

    names = [a.text() for a in window.recent_menu.actions() if not a.isSeparator()]
    assert names == ["first.json", "saved.json", "second.json", "Clear list"]
    close(window, qtbot)

    # A new session lists them too, without files that have gone since.
    second.unlink()
    again = make_window(qtbot, settings_file)
    listed = [a.statusTip() for a in again.recent_menu.actions() if a.statusTip()]
    assert listed == [str(first.resolve()), str(saved.resolve())]
    # Choosing one opens it.
    again.recent_menu.actions()[1].trigger()
    assert again.path == saved.resolve() and again.model.preset.name == "second"
    clear = [a for a in again.recent_menu.actions() if a.text() == "Clear list"][0]
    clear.trigger()
    assert (
        EditorSettings(QSettings(str(settings_file), QSettings.Format.IniFormat)).recent_files()
        == []
    )
    close(again, qtbot)


# -- drag and drop -------------------------------------------------------------------------------


def drop_event(kind, paths: list[Path]):
    mime = QMimeData()
    mime.setUrls([QUrl.fromLocalFile(str(path)) for path in paths])
    args = (Qt.DropAction.CopyAction, mime, Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier)
    if kind is QDragEnterEvent:
        return kind(QPointF(50, 50).toPoint(), *args), mime
    return kind(QPointF(50, 50), *args), mime


def test_a_dropped_preset_file_opens(qtbot, settings_file, tmp_path):
    path = preset_file(tmp_path, "dropped", 7)
    text = tmp_path / "notes.txt"
    text.write_text("not a preset")
    window = make_window(qtbot, settings_file)

    enter, _ = drop_event(QDragEnterEvent, [text])
    QApplication.sendEvent(window, enter)
    assert not enter.isAccepted(), "a text file is not offered as a preset"
    enter, _ = drop_event(QDragEnterEvent, [text, path])
    QApplication.sendEvent(window, enter)
    assert enter.isAccepted()

    drop, _ = drop_event(QDropEvent, [text, path])
    QApplication.sendEvent(window, drop)
    assert window.path == path
    assert window.model.preset.name == "dropped"
    assert window.model.preset.generation.seed == 7
    close(window, qtbot)


def test_a_dropped_broken_file_keeps_the_current_preset(
    qtbot, settings_file, tmp_path, monkeypatch
):
    broken = tmp_path / "broken.json"
    broken.write_text("{ not json")
    window = make_window(qtbot, settings_file)
    errors = []
    monkeypatch.setattr(
        "sand_editor.app._window.QMessageBox.critical",
        lambda parent, title, text: errors.append(text),
    )
    enter, _ = drop_event(QDragEnterEvent, [broken])
    QApplication.sendEvent(window, enter)
    drop, _ = drop_event(QDropEvent, [broken])
    QApplication.sendEvent(window, drop)
    assert errors and "broken.json" in errors[0]
    assert window.model.preset == Preset()
    close(window, qtbot)


# -- baking --------------------------------------------------------------------------------------


def test_bake_from_the_window_writes_the_bake_outputs(qtbot, settings_file, tmp_path):
    window = make_window(qtbot, settings_file)
    out = tmp_path / "baked"
    progress = []
    dialog = window.bake_to(out, 256)
    progress = []
    dialog.job.progressed.connect(lambda fraction, step: progress.append(fraction))
    assert not window.bake_action.isEnabled()
    qtbot.waitUntil(lambda: window.bake_dialog is None, timeout=TIMEOUT_MS)

    assert dialog.error is None and dialog.result is not None
    assert sorted(p.name for p in out.iterdir()) == sorted([*FILES, "material.json"])
    record = json.loads((out / "material.json").read_text())
    assert record["size"] == 256 and record["preset"]["name"] == window.model.preset.name
    assert progress == sorted(progress) and progress[-1] == 1.0
    assert window.bake_action.isEnabled()
    assert "Baked" in window.statusBar().currentMessage()
    close(window, qtbot)


def test_a_cancelled_bake_leaves_the_folder_as_it_was(qtbot, settings_file, tmp_path):
    window = make_window(qtbot, settings_file)
    out = tmp_path / "previous-bake"
    out.mkdir()
    (out / "albedo.png").write_bytes(b"an earlier bake")
    dialog = window.bake_to(out, 2048)
    progress = []
    dialog.job.progressed.connect(lambda fraction, step: progress.append(fraction))
    qtbot.waitUntil(lambda: bool(progress), timeout=TIMEOUT_MS)  # under way
    assert dialog.isVisible() and window.bake_dialog is dialog
    qtbot.wait(20)  # the window still answers while the worker bakes

    dialog.findChild(QPushButton).click()
    qtbot.waitUntil(lambda: window.bake_dialog is None, timeout=TIMEOUT_MS)

    assert max(progress) < 1.0
    assert dialog.result is None and dialog.error is None
    assert [p.name for p in out.iterdir()] == ["albedo.png"]
    assert (out / "albedo.png").read_bytes() == b"an earlier bake"
    assert "cancelled" in window.statusBar().currentMessage()
    close(window, qtbot)


def test_export_from_the_window_writes_a_glb_that_opens_as_a_new_preset(
    qtbot, settings_file, tmp_path
):
    window = make_window(qtbot, settings_file, Preset.load(bundled_preset("red-desert")))
    out = tmp_path / "red.glb"
    dialog = window.bake_to(out, 128, export=True, tiles=2)
    assert dialog.windowTitle() == "Export glTF"
    assert not window.export_action.isEnabled() and not window.bake_action.isEnabled()
    qtbot.waitUntil(lambda: window.bake_dialog is None, timeout=TIMEOUT_MS)
    assert dialog.error is None and dialog.result["format"] == "glb"
    assert out.is_file() and not list(tmp_path.glob(".red.glb.*")), "no temporary left"
    assert "Exported" in window.statusBar().currentMessage()
    assert "2×2 varied tiles" in window.statusBar().currentMessage()
    assert window.export_action.isEnabled()
    material = glb_json(out)["materials"][0]
    assert material["extras"]["sand_editor"]["tiles"] == 2

    window.new_preset()
    assert window.open_path(out)
    assert window.model.preset == Preset.load(bundled_preset("red-desert"))
    # An imported glTF is not overwritten by Save: it is a new preset's source.
    assert window._path is None
    close(window, qtbot)


def test_a_bake_into_an_unwritable_place_says_why(qtbot, settings_file, tmp_path, monkeypatch):
    window = make_window(qtbot, settings_file)
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    errors = []
    monkeypatch.setattr(
        "sand_editor.app._window.QMessageBox.critical",
        lambda parent, title, text: errors.append(text),
    )
    dialog = window.bake_to(blocker / "out", 128)
    qtbot.waitUntil(lambda: window.bake_dialog is None, timeout=TIMEOUT_MS)
    assert dialog.error is not None and str(blocker / "out") in dialog.error
    assert errors == [dialog.error]
    close(window, qtbot)


# -- screenshots ---------------------------------------------------------------------------------


def test_save_screenshot_writes_the_window_as_png(qtbot, settings_file, tmp_path):
    window = make_window(qtbot, settings_file)
    shots = tmp_path / "shots"
    shots.mkdir()
    path = shots / "window.png"
    window.write_screenshot(path)
    image = Image.open(path)
    assert image.size == (window.width(), window.height())
    assert [p.name for p in shots.iterdir()] == ["window.png"], "no temporary file is left"
    missing = tmp_path / "missing-folder" / "window.png"
    with pytest.raises(OutputError, match="missing-folder.*folder does not exist"):
        window.write_screenshot(missing)
    close(window, qtbot)


@pytest.mark.parametrize("tab", ["albedo", "normals", "glint", "layers", "3d"])
def test_screenshot_option_saves_each_tab_and_exits(tmp_path, tab):
    path = tmp_path / f"{tab}.png"
    result = run_python(
        "-m",
        "sand_editor",
        "red-desert",
        "--screenshot",
        str(path),
        "--tab",
        tab,
        env={"XDG_CONFIG_HOME": str(tmp_path / "cfg")},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert "Traceback" not in result.stderr
    pixels = np.asarray(Image.open(path).convert("RGB")).astype(float)
    assert pixels.shape == (820, 1280, 3)
    # The preview's right part shows the tab's content: varied, not a blank widget.
    preview = pixels[200:700, 700:1200]
    assert preview.std() > 5.0, tab
    if tab == "3d":
        assert preview.mean() > 60.0, "the desert at 10:00 is not dark"
        red, green, blue = preview.reshape(-1, 3).mean(axis=0)
        assert red > green > blue, "red-desert sand is red"
    assert not (tmp_path / "cfg").exists(), "a screenshot run remembers nothing"


def test_screenshot_option_with_an_unwritable_file_exits_1(tmp_path):
    result = run_python("-m", "sand_editor", "--screenshot", str(tmp_path / "no" / "x.png"))
    assert result.returncode == 1
    assert "cannot write" in result.stderr


# -- remembered settings -------------------------------------------------------------------------


def test_layout_tab_and_3d_view_settings_are_restored(qtbot, settings_file):
    window = make_window(qtbot, settings_file)
    window.resize(700, 500)  # within Xvfb's 800×600 screen (the panels may need more width)
    size = (window.width(), window.height())
    assert size != (1280, 820)
    window.splitter.setSizes([300, 700])
    sizes = window.splitter.sizes()
    panel = open_3d(window, qtbot)
    panel.set_distance(5.0)
    panel.mode_combo.setCurrentText("blend")
    panel.sphere.setChecked(True)
    panel.time_slider.setValue(17 * 60 + 30)
    close(window, qtbot)

    again = make_window(qtbot, settings_file)
    # Xvfb's screen is 800 px wide, narrower than the panels' minimum width: Qt fits the
    # restored width to the screen; the height is restored as it was.
    assert again.height() == size[1] and again.width() < 1280
    assert again.splitter.sizes()[0] == sizes[0]  # the panel; the preview takes the rest
    assert again.preview.channel == "3D"
    view = again.preview.view3d.view
    assert view.distance_m == pytest.approx(5.0)
    assert view.mode == "blend" and view.show_sphere
    assert view.time_hours == pytest.approx(17.5)
    stored = QSettings(str(settings_file), QSettings.Format.IniFormat)
    assert int(stored.value("schema_version")) == SCHEMA_VERSION
    close(again, qtbot)


def test_unreadable_or_newer_settings_are_ignored(qtbot, settings_file):
    store = QSettings(str(settings_file), QSettings.Format.IniFormat)
    store.setValue("view3d/distance_m", "far away")
    store.setValue("view3d/mode", "no-such-mode")
    store.setValue("window/tab", 99)
    store.sync()
    window = make_window(qtbot, settings_file)
    assert window.preview.channel == "Albedo"
    panel = open_3d(window, qtbot)
    assert panel.view.distance_m == pytest.approx(1.0) and panel.view.mode == "full"
    close(window, qtbot)

    store = QSettings(str(settings_file), QSettings.Format.IniFormat)
    store.setValue("schema_version", SCHEMA_VERSION + 1)
    store.setValue("window/tab", 2)
    store.sync()
    assert (
        EditorSettings(QSettings(str(settings_file), QSettings.Format.IniFormat)).layout()["tab"]
        is None
    )


def test_tooltips_list_the_shortcuts(window):
    tips = {
        a.text().replace("&", ""): a.toolTip()
        for a in window.findChildren(type(window.bake_action))
    }
    assert "Ctrl+O" in tips["Open…"]
    assert "Ctrl+S" in tips["Save"]
    assert "Ctrl+B" in tips["Bake textures…"]
    assert "Ctrl+Z" in window.undo_action.toolTip()
    assert "Ctrl+5" in window.preview.tabs.tabToolTip(4)
    window.model.edit("generation.seed", 3)
    assert "Ctrl+Z" in window.undo_action.toolTip() and "Seed" in window.undo_action.toolTip()


def test_view_menu_switches_tabs_and_takes_more_views(window):
    actions = [a for a in window.view_menu.actions() if not a.isSeparator()]
    actions[2].trigger()
    assert window.preview.channel == "Glint"
    from PySide6.QtGui import QAction

    extra = QAction("Extra view", window)
    extra.setShortcut("Ctrl+Shift+E")
    window.add_view_action(extra)
    assert extra in window.view_menu.actions() and extra in window.toolbar.actions()
    assert "Ctrl+Shift+E" in extra.toolTip()


def test_bundled_preset_is_not_remembered_as_recent(qtbot, settings_file):
    window = make_window(qtbot, settings_file)
    window.open_bundled("red-desert")
    assert not window.recent_menu.isEnabled()
    assert window.path is None and window._source == bundled_preset("red-desert")
    close(window, qtbot)


def test_schema_1_settings_keep_the_clock_in_the_new_units(qtbot, settings_file):
    store = QSettings(str(settings_file), QSettings.Format.IniFormat)
    store.setValue("schema_version", 1)
    store.setValue("view3d/time_hours", 17.25)
    store.setValue("view3d/day_speed", 3600)  # simulated seconds per real second
    store.sync()
    window = make_window(qtbot, settings_file)
    state = window.view_model.state
    assert state.hours == pytest.approx(17.25)
    assert state.playing and state.day_speed == pytest.approx(1.0)  # an hour a second
    close(window, qtbot)
    stored = QSettings(str(settings_file), QSettings.Format.IniFormat)
    assert int(stored.value("schema_version")) == SCHEMA_VERSION == 2
    assert stored.value("view3d/time_hours") is None
