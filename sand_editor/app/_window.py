"""The editor's main window: parameter panel, preview, file menu, undo and status bar."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
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

from sand_editor.app._controls import ControlsPanel
from sand_editor.app._model import PresetModel
from sand_editor.app._preview import PreviewPanel
from sand_editor.app._regenerator import Regenerator
from sand_editor.app._vr_controls import VrControls
from sand_editor.generator import SandTextures
from sand_editor.preset import FIELDS, Preset, PresetError
from sand_editor.resources import bundled_preset, presets_dir, ui_dir

_REGENERATING = frozenset(spec.path for spec in FIELDS if spec.regenerates)
_FILE_FILTER = "Sand presets (*.json);;All files (*)"
STATUS_MESSAGE_MS = 6000


class EditorWindow(QMainWindow):
    """Edits one preset at a time.

    Parameters
    ----------
    preset
        The preset to start with.
    path
        Where Save writes it; None for a new preset or a bundled one (Save asks for a file).
    source
        What Revert reloads, when it differs from ``path`` (a bundled preset).
    """

    def __init__(
        self,
        preset: Preset | None = None,
        path: str | Path | None = None,
        source: str | Path | None = None,
        parent: QWidget | None = None,
    ):
        super().__init__(parent)
        self.resize(1280, 820)
        self.setStyleSheet((ui_dir() / "editor.qss").read_text(encoding="utf-8"))
        self.model = PresetModel(preset, self)
        self._path = Path(path) if path is not None else None
        self._source = Path(source) if source is not None else self._path

        self.controls = ControlsPanel(self.model)
        panel_scroll = QScrollArea()
        panel_scroll.setWidget(self.controls)
        panel_scroll.setWidgetResizable(True)
        panel_scroll.setMinimumWidth(self.controls.sizeHint().width() + 24)
        self.preview = PreviewPanel(model=self.model)
        splitter = QSplitter(Qt.Orientation.Horizontal, self)
        splitter.addWidget(panel_scroll)
        splitter.addWidget(self.preview)
        splitter.setStretchFactor(1, 1)
        self.setCentralWidget(splitter)

        self.statistics_label = QLabel("Generating…", objectName="statistics")
        self.statusBar().addPermanentWidget(self.statistics_label)

        self.regenerator = Regenerator(self.preview.preview_size, self)
        self.regenerator.produced.connect(self.preview.show_textures)
        self.regenerator.finished.connect(self._show_statistics)
        self.regenerator.failed.connect(self._show_generation_error)
        self.preview.size_changed.connect(self.regenerator.set_size)

        self.model.changed.connect(self._on_preset_changed)
        self.model.refused.connect(lambda text: self.statusBar().showMessage(text, 10_000))
        self.model.undo_stack.cleanChanged.connect(self._update_title)
        self._build_actions()
        self.vr = VrControls(self)  # the "View in VR" button, menu and link to the viewer
        self._update_title()
        self.regenerator.request(self.model.preset)

    # -- documents -----------------------------------------------------------------------------

    @property
    def path(self) -> Path | None:
        return self._path

    def open_path(self, path: str | Path) -> bool:
        """Load a preset file; on failure show the error and keep the current work."""
        return self._load(Path(path), save_path=Path(path))

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
        start = str(self._path or Path.home() / f"{self.model.preset.name}.json")
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
        quit_ = self._action("&Quit", self.close, key.Quit)

        stack = self.model.undo_stack
        self.undo_action = stack.createUndoAction(self, "&Undo")
        self.undo_action.setShortcut(QKeySequence(key.Undo))
        self.redo_action = stack.createRedoAction(self, "&Redo")
        self.redo_action.setShortcuts([QKeySequence("Ctrl+Shift+Z"), QKeySequence("Ctrl+Y")])

        file_menu = self.menuBar().addMenu("&File")
        file_menu.addActions([new, open_])
        bundled = file_menu.addMenu("Open &bundled preset")
        for preset_file in sorted(presets_dir().glob("*.json")):
            bundled.addAction(
                preset_file.stem, lambda name=preset_file.stem: self._ask_open_bundled(name)
            )
        file_menu.addSeparator()
        file_menu.addActions([save, save_as, self.revert_action])
        file_menu.addSeparator()
        file_menu.addAction(quit_)
        edit_menu = self.menuBar().addMenu("&Edit")
        edit_menu.addActions([self.undo_action, self.redo_action])

        toolbar = self.addToolBar("File")
        toolbar.setObjectName("file-toolbar")
        toolbar.addActions([new, open_, save])
        toolbar.addSeparator()
        toolbar.addActions([self.undo_action, self.redo_action])

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

    def _show_statistics(self, textures: SandTextures, seconds: float) -> None:
        stats = textures.statistics(self.model.preset.generation.layers)
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
