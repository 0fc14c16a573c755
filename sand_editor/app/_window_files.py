"""The editor window's ways in and out for files other than presets: recent files and dropped
presets, baking the textures, and screenshots of the window."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QBuffer, QByteArray, QIODevice
from PySide6.QtWidgets import QFileDialog, QInputDialog, QMessageBox

from sand_editor.app._bake import BakeDialog, BakeJob
from sand_editor.export.variation import EXPORT_TILES
from sand_editor.files import OutputError, file_stem, write_atomic
from sand_editor.generator.sizes import BAKE_SIZES, DEFAULT_BAKE_SIZE, DEFAULT_EXPORT_SIZE
from sand_editor.preset import GLTF_SUFFIXES

_IMAGE_FILTER = "PNG images (*.png)"
STATUS_MESSAGE_MS = 6000


class WindowFiles:
    """Part of ``EditorWindow`` (a mixin): uses its ``settings``, ``model``, ``recent_menu``,
    ``bake_action``, ``maybe_save`` and ``open_path``."""

    # -- recent files, drops ---------------------------------------------------------------------

    def _remember_recent(self, path: Path) -> None:
        if self.settings is not None:
            self.settings.add_recent(path)
            self._fill_recent_menu()

    def _fill_recent_menu(self) -> None:
        self.recent_menu.clear()
        recent = self.settings.recent_files() if self.settings is not None else []
        for path in recent:
            self.recent_menu.addAction(
                path.name, lambda _=False, p=path: self._ask_open_path(p)
            ).setStatusTip(str(path))
        if recent:
            self.recent_menu.addSeparator()
            self.recent_menu.addAction("Clear list", self._clear_recent)
        self.recent_menu.setEnabled(bool(recent))

    def _clear_recent(self) -> None:
        if self.settings is not None:
            self.settings.clear_recent()
        self._fill_recent_menu()

    def _ask_open_path(self, path: Path) -> None:
        if self.maybe_save():
            self.open_path(path)

    def dragEnterEvent(self, event) -> None:
        if _dropped_preset(event.mimeData()) is not None:
            event.acceptProposedAction()

    def dropEvent(self, event) -> None:
        path = _dropped_preset(event.mimeData())
        if path is not None:
            event.acceptProposedAction()
            self._ask_open_path(path)

    # -- bake, screenshots -----------------------------------------------------------------------

    def _ask_bake(self) -> None:
        start = str(self._path.parent if self._path else Path.cwd())
        folder = QFileDialog.getExistingDirectory(self, "Bake textures into folder", start)
        if not folder:
            return
        sizes = [str(size) for size in BAKE_SIZES]
        size, ok = QInputDialog.getItem(
            self,
            "Bake textures",
            "Texture size (pixels):",
            sizes,
            sizes.index(str(DEFAULT_BAKE_SIZE)),
            False,
        )
        if ok:
            self.bake_to(Path(folder), int(size))

    def suggested_file(self, folder: Path, suffix: str) -> str:
        """The file a save dialog offers: the preset's name as a file stem (a name from a
        downloaded file may hold separators or ``..``), in ``folder``."""
        return str(folder / f"{file_stem(self.model.preset.name)}{suffix}")

    def _ask_export(self) -> None:
        start = self.suggested_file(self._path.parent if self._path else Path.cwd(), ".glb")
        chosen, _ = QFileDialog.getSaveFileName(
            self, "Export glTF", start, "glTF binary (*.glb);;glTF with files (*.gltf)"
        )
        if not chosen:
            return
        if Path(chosen).suffix.lower() not in (".glb", ".gltf"):
            chosen += ".glb"
        choices = [str(tiles) for tiles in EXPORT_TILES]
        tiles, ok = QInputDialog.getItem(
            self,
            "Export glTF",
            "Varied tiles across the images (the pattern repeats this many tiles apart;\n"
            "the images grow as many times wider):",
            choices,
            0,
            False,
        )
        if ok:
            self.bake_to(Path(chosen), DEFAULT_EXPORT_SIZE, export=True, tiles=int(tiles))

    def bake_to(self, folder: Path, size: int, export: bool = False, tiles: int = 1) -> BakeDialog:
        """Start baking the current preset into ``folder`` (with ``export``: the glTF asset to
        that file, its images ``tiles`` varied tiles across); returns the open progress
        dialog."""
        job = BakeJob(self.model.preset, size, Path(folder), self, export=export, tiles=tiles)
        dialog = BakeDialog(job, self)
        dialog.finished.connect(lambda: self._bake_done(dialog))
        self.bake_dialog = dialog
        self.bake_action.setEnabled(False)
        self.export_action.setEnabled(False)
        dialog.open()
        job.start()
        return dialog

    def _bake_done(self, dialog: BakeDialog) -> None:
        self.bake_dialog = None
        self.bake_action.setEnabled(True)
        self.export_action.setEnabled(True)
        job = dialog.job
        if dialog.error is not None:
            QMessageBox.critical(
                self, "Cannot export" if job.export else "Cannot bake", dialog.error
            )
        elif dialog.result is not None:
            if job.export:
                tiles = f", {job.tiles}×{job.tiles} varied tiles" if job.tiles > 1 else ""
                message = f"Exported {job.out_dir} ({job.size}² textures{tiles})"
            else:
                message = f"Baked {job.size}² textures into {job.out_dir}"
            self.statusBar().showMessage(message, STATUS_MESSAGE_MS)
        else:
            stopped = "Export" if job.export else "Bake"
            self.statusBar().showMessage(f"{stopped} cancelled; nothing written", STATUS_MESSAGE_MS)

    def _ask_screenshot(self) -> None:
        start = self.suggested_file(Path.cwd(), ".png")
        chosen, _ = QFileDialog.getSaveFileName(self, "Save screenshot", start, _IMAGE_FILTER)
        if chosen:
            path = Path(chosen) if Path(chosen).suffix else Path(chosen).with_suffix(".png")
            try:
                self.write_screenshot(path)
            except OutputError as error:
                QMessageBox.critical(self, "Cannot save screenshot", str(error))
            else:
                self.statusBar().showMessage(f"Saved {path}", STATUS_MESSAGE_MS)

    def write_screenshot(self, path: str | Path) -> None:
        """Write the window as shown to a PNG file (atomically); OutputError names the file."""
        data = QByteArray()
        buffer = QBuffer(data)
        buffer.open(QIODevice.OpenModeFlag.WriteOnly)
        if not self.grab().save(buffer, "PNG"):
            raise OutputError(path, "cannot encode the window as PNG")
        buffer.close()
        write_atomic(path, data.data())


def _dropped_preset(mime) -> Path | None:
    """The first local preset file (.json, or an exported .glb or .gltf) among dropped URLs, or
    None."""
    for url in mime.urls() if mime.hasUrls() else []:
        if url.isLocalFile():
            path = Path(url.toLocalFile())
            if path.suffix.lower() in (".json", *GLTF_SUFFIXES) and path.is_file():
                return path
    return None
