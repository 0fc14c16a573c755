"""The editor's main window: parameter panel, preview, file menu, undo and status bar."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QSettings, Qt
from PySide6.QtGui import QAction, QCloseEvent, QKeySequence
from PySide6.QtWidgets import (
    QFileDialog,
    QLabel,
    QMainWindow,
    QMessageBox,
    QScrollArea,
    QSplitter,
    QWidget,
)

from sand_editor.app._bake import BakeDialog
from sand_editor.app._controls import ControlsPanel
from sand_editor.app._model import PresetModel
from sand_editor.app._preview import CHANNELS, TAB_3D, PreviewPanel
from sand_editor.app._regenerator import Regenerator
from sand_editor.app._settings import EditorSettings
from sand_editor.app._vr_controls import VrControls
from sand_editor.app._window_files import STATUS_MESSAGE_MS, WindowFiles
from sand_editor.generator import SandTextures
from sand_editor.preset import FIELDS, GLTF_SUFFIXES, Preset, PresetError
from sand_editor.resources import bundled_preset, presets_dir, ui_dir
from sand_editor.view import ViewModel

_REGENERATING = frozenset(spec.path for spec in FIELDS if spec.regenerates)
_FILE_FILTER = "Sand presets (*.json);;Exported glTF (*.glb *.gltf);;All files (*)"
DEFAULT_SIZE = (1280, 820)


class EditorWindow(WindowFiles, QMainWindow):
    """Edits one preset at a time.

    Parameters
    ----------
    preset
        The preset to start with.
    path
        Where Save writes it; None for a new preset or a bundled one (Save asks for a file).
    source
        What Revert reloads, when it differs from ``path`` (a bundled preset).
    settings
        Where layout, recent files and 3D view settings are remembered; None remembers
        nothing (screenshots for the docs look the same on every machine).
    """

    def __init__(
        self,
        preset: Preset | None = None,
        path: str | Path | None = None,
        source: str | Path | None = None,
        parent: QWidget | None = None,
        settings: QSettings | None = None,
    ):
        super().__init__(parent)
        self.resize(*DEFAULT_SIZE)
        self.setAcceptDrops(True)
        self.settings = EditorSettings(settings) if settings is not None else None
        self.setStyleSheet((ui_dir() / "editor.qss").read_text(encoding="utf-8"))
        self.model = PresetModel(preset, self)
        self._path = Path(path) if path is not None else None
        self._source = Path(source) if source is not None else self._path

        self.controls = ControlsPanel(self.model)
        panel_scroll = QScrollArea()
        panel_scroll.setWidget(self.controls)
        panel_scroll.setWidgetResizable(True)
        panel_scroll.setMinimumWidth(self.controls.sizeHint().width() + 24)
        # The camera, clock and mode: the 3D tab, the settings and the VR link share this model.
        self.view_model = ViewModel()
        self.preview = PreviewPanel(model=self.model, view_model=self.view_model)
        self.splitter = QSplitter(Qt.Orientation.Horizontal, self)
        self.splitter.addWidget(panel_scroll)
        self.splitter.addWidget(self.preview)
        self.splitter.setStretchFactor(1, 1)
        self.setCentralWidget(self.splitter)
        self.bake_dialog: BakeDialog | None = None

        self.statistics_label = QLabel("Generating…", objectName="statistics")
        self.statusBar().addPermanentWidget(self.statistics_label)

        self.regenerator = Regenerator(self.preview.preview_size, self)
        self.regenerator.produced.connect(self._show_tile)
        self.regenerator.finished.connect(self._show_statistics)
        self.regenerator.failed.connect(self._show_generation_error)
        self.preview.size_changed.connect(self.regenerator.set_size)

        self.model.changed.connect(self._on_preset_changed)
        self.model.refused.connect(lambda text: self.statusBar().showMessage(text, 10_000))
        self.model.undo_stack.cleanChanged.connect(self._update_title)
        self._build_actions()
        self.vr = VrControls(self)  # the "View in VR" button, menu and link to the viewer
        self._update_title()
        self._restore_settings()
        self.regenerator.request(self.model.preset)

    # -- documents -----------------------------------------------------------------------------

    @property
    def path(self) -> Path | None:
        return self._path

    def open_path(self, path: str | Path) -> bool:
        """Load a preset file (or the preset inside an exported glTF file, which is then saved
        as a new preset: Save asks where); on failure show the error and keep the current work."""
        path = Path(path)
        imported = path.suffix.lower() in GLTF_SUFFIXES
        return self._load(path, save_path=None if imported else path)

    def open_bundled(self, name: str) -> bool:
        """Load a shipped preset as a template: Save asks where to write the copy."""
        return self._load(bundled_preset(name), save_path=None)

    def new_preset(self) -> None:
        self._set_document(Preset(), path=None, source=None)

    def revert(self) -> None:
        if self._source is None:
            self.model.reset(Preset())
        else:
            self._load(self._source, save_path=self._path)

    def save(self) -> bool:
        if self._path is None:
            return self.save_as()
        return self.save_to(self._path)

    def save_as(self) -> bool:
        start = str(self._path) if self._path else self.suggested_file(Path.home(), ".json")
        chosen, _ = QFileDialog.getSaveFileName(self, "Save preset as", start, _FILE_FILTER)
        if not chosen:
            return False
        path = Path(chosen)
        return self.save_to(path if path.suffix else path.with_suffix(".json"))

    def save_to(self, path: str | Path) -> bool:
        path = Path(path)
        try:
            self.model.preset.save(path)
        except PresetError as error:
            QMessageBox.critical(self, "Cannot save preset", str(error))
            return False
        self._path = self._source = path
        self.model.undo_stack.setClean()
        self._update_title()
        self._remember_recent(path)
        self.statusBar().showMessage(f"Saved {path}", STATUS_MESSAGE_MS)
        return True

    def maybe_save(self) -> bool:
        """Ask about unsaved changes; True when it is fine to discard the current preset."""
        if not self.isWindowModified():
            return True
        answer = QMessageBox.question(
            self,
            "Unsaved changes",
            f"The preset “{self.model.preset.name}” has unsaved changes. Save them?",
            QMessageBox.StandardButton.Save
            | QMessageBox.StandardButton.Discard
            | QMessageBox.StandardButton.Cancel,
            QMessageBox.StandardButton.Save,
        )
        if answer == QMessageBox.StandardButton.Save:
            return self.save()
        return answer == QMessageBox.StandardButton.Discard

    def closeEvent(self, event: QCloseEvent) -> None:
        if self.maybe_save():
            self._save_settings()
            if self.bake_dialog is not None:
                self.bake_dialog.cancel()
            # GL objects go while their context is still whole, not in Qt's teardown at exit.
            self.preview.release_gl()
            self.regenerator.shutdown()
            event.accept()
        else:
            event.ignore()

    def _load(self, path: Path, save_path: Path | None) -> bool:
        try:
            preset = Preset.load(path)
        except PresetError as error:
            QMessageBox.critical(self, "Cannot open preset", str(error))
            return False
        self._set_document(preset, path=save_path, source=path)
        if save_path is not None:
            self._remember_recent(path)
        self.statusBar().showMessage(f"Opened {path}", STATUS_MESSAGE_MS)
        return True

    def _set_document(self, preset: Preset, path: Path | None, source: Path | None) -> None:
        self._path, self._source = path, source
        self.model.reset(preset)
        self._update_title()

    # -- actions -------------------------------------------------------------------------------

    def _action(self, text: str, slot, shortcut=None, tip: str = "") -> QAction:
        action = QAction(text, self)
        if shortcut is not None:
            action.setShortcut(QKeySequence(shortcut))
        action.setStatusTip(tip)
        action.triggered.connect(slot)
        return action

    def _build_actions(self) -> None:
        key = QKeySequence.StandardKey
        new = self._action("&New", self._ask_new, key.New, "Start from the default preset")
        open_ = self._action("&Open…", self._ask_open, key.Open, "Open a preset file")
        save = self._action("&Save", self.save, key.Save, "Save to the current file")
        save_as = self._action("Save &As…", self.save_as, key.SaveAs, "Save to a new file")
        self.revert_action = self._action("&Revert", self._ask_revert, tip="Reload the file")
        self.bake_action = self._action(
            "&Bake textures…", self._ask_bake, "Ctrl+B", "Write the grain textures as PNG files"
        )
        self.export_action = self._action(
            "&Export glTF…", self._ask_export, "Ctrl+E", "Write a sand patch as a glTF 2.0 asset"
        )
        self.screenshot_action = self._action(
            "Save scree&nshot…", self._ask_screenshot, "Ctrl+Shift+S", "Save the window as PNG"
        )
        # Ctrl+Shift+S is Save As's shortcut where the platform has one: use F12 there.
        if QKeySequence("Ctrl+Shift+S") in save_as.shortcuts():
            self.screenshot_action.setShortcut(QKeySequence("F12"))
        quit_ = self._action("&Quit", self.close, key.Quit, "Close the editor")

        stack = self.model.undo_stack
        self.undo_action = stack.createUndoAction(self, "&Undo")
        self.undo_action.setShortcut(QKeySequence(key.Undo))
        self.redo_action = stack.createRedoAction(self, "&Redo")
        self.redo_action.setShortcuts([QKeySequence("Ctrl+Shift+Z"), QKeySequence("Ctrl+Y")])

        file_menu = self.menuBar().addMenu("&File")
        file_menu.addActions([new, open_])
        self.recent_menu = file_menu.addMenu("Open &recent")
        self.recent_menu.aboutToShow.connect(self._fill_recent_menu)
        self._fill_recent_menu()
        bundled = file_menu.addMenu("Open &bundled preset")
        for preset_file in sorted(presets_dir().glob("*.json")):
            bundled.addAction(
                preset_file.stem, lambda name=preset_file.stem: self._ask_open_bundled(name)
            )
        file_menu.addSeparator()
        file_menu.addActions([save, save_as, self.revert_action])
        file_menu.addSeparator()
        file_menu.addActions([self.bake_action, self.export_action, self.screenshot_action])
        file_menu.addSeparator()
        file_menu.addAction(quit_)
        edit_menu = self.menuBar().addMenu("&Edit")
        edit_menu.addActions([self.undo_action, self.redo_action])
        # The View menu lists the preview's tabs; add_view_action puts more views here.
        self.view_menu = self.menuBar().addMenu("&View")
        for index, name in enumerate((*CHANNELS, TAB_3D)):
            action = self._action(
                f"&{index + 1} {name}",
                lambda _=False, i=index: self.preview.tabs.setCurrentIndex(i),
                f"Ctrl+{index + 1}",
                f"Show the {name} tab",
            )
            self.view_menu.addAction(action)
            self.preview.tabs.setTabToolTip(index, _with_shortcut(f"Show {name}", action))

        self.toolbar = self.addToolBar("File")
        self.toolbar.setObjectName("file-toolbar")
        self.toolbar.addActions([new, open_, save])
        self.toolbar.addSeparator()
        self.toolbar.addActions([self.undo_action, self.redo_action])
        self.toolbar.addSeparator()
        self.toolbar.addActions([self.bake_action])
        for action in (new, open_, save, save_as, self.revert_action, self.bake_action):
            action.setToolTip(_with_shortcut(action.statusTip(), action))
        for action in (self.screenshot_action, quit_, self.undo_action, self.redo_action):
            action.setToolTip(_with_shortcut(action.text().replace("&", ""), action))
        # Undo and redo rename themselves after each edit ("Undo Change Seed").
        stack.undoTextChanged.connect(self._update_undo_tips)
        stack.redoTextChanged.connect(self._update_undo_tips)

    def _update_undo_tips(self) -> None:
        for action in (self.undo_action, self.redo_action):
            action.setToolTip(_with_shortcut(action.text().replace("&", ""), action))

    def add_view_action(self, action: QAction) -> None:
        """Offer another way to look at the preset (a menu entry under View, and a button)."""
        action.setToolTip(_with_shortcut(action.statusTip() or action.text(), action))
        self.view_menu.addSeparator()
        self.view_menu.addAction(action)
        self.toolbar.addSeparator()
        self.toolbar.addAction(action)

    def _ask_new(self) -> None:
        if self.maybe_save():
            self.new_preset()

    def _ask_open(self) -> None:
        if not self.maybe_save():
            return
        start = str(self._path.parent if self._path else Path.cwd())
        chosen, _ = QFileDialog.getOpenFileName(self, "Open preset", start, _FILE_FILTER)
        if chosen:
            self.open_path(chosen)

    def _ask_open_bundled(self, name: str) -> None:
        if self.maybe_save():
            self.open_bundled(name)

    def _ask_revert(self) -> None:
        if not self.isWindowModified():
            return
        answer = QMessageBox.question(
            self,
            "Revert",
            "Discard all unsaved changes?",
            QMessageBox.StandardButton.Discard | QMessageBox.StandardButton.Cancel,
        )
        if answer == QMessageBox.StandardButton.Discard:
            self.revert()

    # -- settings --------------------------------------------------------------------------------

    def _restore_settings(self) -> None:
        if self.settings is None:
            return
        layout = self.settings.layout()
        # The tab first: the 3D tab's controls widen the window's minimum size.
        with self.view_model.blocked():  # nothing is listening yet that needs telling
            self.view_model.update(self, **self.settings.view3d().to_dict())
        if layout["tab"] is not None and 0 <= layout["tab"] < self.preview.tabs.count():
            self.preview.tabs.setCurrentIndex(layout["tab"])
        if layout["geometry"] is not None:
            self.restoreGeometry(layout["geometry"])
        if layout["state"] is not None:
            self.restoreState(layout["state"])
        if layout["splitter"] is not None:
            self.splitter.restoreState(layout["splitter"])

    def _save_settings(self) -> None:
        if self.settings is None:
            return
        self.settings.save_layout(
            self.saveGeometry(),
            self.saveState(),
            self.splitter.saveState(),
            self.preview.tabs.currentIndex(),
        )
        self.settings.save_view3d(self.view_model.state)
        self.settings.sync()

    # -- reactions -----------------------------------------------------------------------------

    def _on_preset_changed(self, preset: Preset, paths: frozenset[str]) -> None:
        if paths & _REGENERATING:
            self.regenerator.request(preset)
        if "name" in paths:
            self._update_title()

    def _update_title(self) -> None:
        if self._path is not None:
            where = str(self._path)
        elif self._source is not None:
            where = f"{self._source.name} (bundled, unsaved)"
        else:
            where = "unsaved"
        self.setWindowTitle(f"{self.model.preset.name} — {where}[*]")
        modified = not self.model.undo_stack.isClean()
        self.setWindowModified(modified)
        self.revert_action.setEnabled(modified)

    def _show_tile(self, textures: SandTextures, final: bool) -> None:
        self.preview.show_textures(textures, final)
        if final:
            self.preview.set_grains(textures)

    def _show_statistics(self, textures: SandTextures, seconds: float) -> None:
        stats = self.regenerator.statistics
        coverage = stats["coverage_per_layer"]
        top = f"{coverage[0]:.1%}" if coverage else "—"
        self.statistics_label.setText(
            f"{textures.size}×{textures.size} in {seconds * 1000:.0f} ms · "
            f"top layer {top} · gaps {stats['gap_fraction']:.1%} · "
            f"{stats['grain_count']} grains"
        )

    def _show_generation_error(self, message: str) -> None:
        self.preview.show_message(message)
        self.statistics_label.setText("Generation failed")
        self.statusBar().showMessage(message)


def _with_shortcut(text: str, action: QAction) -> str:
    shortcut = action.shortcut().toString(QKeySequence.SequenceFormat.NativeText)
    return f"{text} ({shortcut})" if shortcut else text
