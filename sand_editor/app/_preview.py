"""The texture preview: one tab per generated map, with tiling and nearest-neighbour zoom, and a
"3D" tab with the live rendered desert."""

from __future__ import annotations

import colorsys

import numpy as np
from PySide6.QtCore import QSize, Qt, Signal
from PySide6.QtGui import QImage, QPixmap
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QHBoxLayout,
    QLabel,
    QScrollArea,
    QStackedWidget,
    QTabBar,
    QVBoxLayout,
    QWidget,
)

from sand_editor.app._view3d import View3DPanel
from sand_editor.colour import linear_to_srgb
from sand_editor.generator import SandTextures
from sand_editor.generator.noise import MAX_LAYERS
from sand_editor.generator.sizes import DEFAULT_PREVIEW_SIZE, PREVIEW_SIZES
from sand_editor.view import ViewModel

CHANNELS = ("Albedo", "Normals", "Glint", "Layers")
TAB_3D = "3D"
ZOOMS = {"Fit": None, "1:1": 1, "2:1": 2}


def _layer_palette() -> np.ndarray:
    # Golden-ratio hue steps keep neighbouring layers far apart in colour; gaps are black.
    colors = [(0.0, 0.0, 0.0)]
    colors += [colorsys.hsv_to_rgb((i * 0.618034) % 1.0, 0.75, 0.95) for i in range(MAX_LAYERS)]
    return (np.array(colors) * 255 + 0.5).astype(np.uint8)


LAYER_PALETTE = _layer_palette()
# Linear [0, 1] in 1/65535 steps to 8-bit sRGB: one table look-up per channel instead of a
# power per channel, which at 1024² took longer than the generation itself.
_SRGB_STEPS = 65535
_SRGB_TABLE = (
    np.clip(linear_to_srgb(np.linspace(0.0, 1.0, _SRGB_STEPS + 1)), 0.0, 1.0) * 255 + 0.5
).astype(np.uint8)


def _unit_to_8bit(values: np.ndarray, scale: float = 1.0, offset: float = 0.0) -> np.ndarray:
    encoded = values * np.float32(scale * 255.0) + np.float32(offset * 255.0 + 0.5)
    return np.clip(encoded, 0.0, 255.0, out=encoded).astype(np.uint8)


def channel_rgb(textures: SandTextures, channel: str) -> np.ndarray:
    """8-bit sRGB image (size, size, 3) of one map, as shown on screen."""
    if channel == "Albedo":
        albedo = np.clip(textures.albedo, 0.0, 1.0) * np.float32(_SRGB_STEPS)
        return _SRGB_TABLE[(albedo + np.float32(0.5)).astype(np.uint16)]
    if channel == "Normals":
        return _unit_to_8bit(textures.normal, 0.5, 0.5)
    if channel == "Glint":
        return np.repeat(_unit_to_8bit(textures.glint)[..., None], 3, axis=2)
    if channel == "Layers":
        return LAYER_PALETTE[textures.layer.astype(np.int64) + 1]
    raise ValueError(f"unknown channel {channel!r}; allowed: {', '.join(CHANNELS)}")


def rgb_to_qimage(rgb: np.ndarray) -> QImage:
    rgb = np.ascontiguousarray(rgb)
    height, width, _ = rgb.shape
    # copy(): the QImage must own its pixels, not borrow the numpy buffer.
    return QImage(rgb.data, width, height, 3 * width, QImage.Format.Format_RGB888).copy()


class PreviewPanel(QWidget):
    """Shows the latest generated tile; emits ``size_changed(int)`` for the preview size combo."""

    size_changed = Signal(int)

    def __init__(self, parent: QWidget | None = None, model=None, view_model=None):
        super().__init__(parent)
        self._model = model
        self.view_model = view_model if view_model is not None else ViewModel()
        self.view3d = None  # the 3D panel, made when its tab is first shown
        self._textures: SandTextures | None = None
        # The latest full tile (it names its generation), for the 3D view.
        self._grains: SandTextures | None = None
        self._image = QImage()
        self._target_size = DEFAULT_PREVIEW_SIZE

        self.tabs = QTabBar(self, objectName="preview-tabs")
        for channel in CHANNELS:
            self.tabs.addTab(channel)
        if model is not None:
            self.tabs.addTab(TAB_3D)
        self.tiling = QCheckBox("Tile 2×2", self, objectName="preview-tiling")
        self.tiling.setToolTip("Show four copies of the tile, so seams would be visible.")
        self.zoom = QComboBox(self, objectName="preview-zoom")
        self.zoom.addItems(list(ZOOMS))
        self.zoom.setToolTip("Fit the window, or show texels 1:1 or 2:1 (nearest neighbour).")
        self.size_combo = QComboBox(self, objectName="preview-size")
        for size in PREVIEW_SIZES:
            self.size_combo.addItem(f"{size} px", size)
        self.size_combo.setCurrentIndex(PREVIEW_SIZES.index(DEFAULT_PREVIEW_SIZE))
        self.size_combo.setToolTip("Resolution of the generated preview tile.")

        self.view = QLabel(objectName="preview-image")
        self.view.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.scroll = QScrollArea(self)
        self.scroll.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.scroll.setWidget(self.view)
        self.scroll.setWidgetResizable(True)

        bar = QHBoxLayout()
        bar.addWidget(self.tabs)
        bar.addStretch(1)
        self._texture_options = []
        for label, widget in (("", self.tiling), ("Zoom", self.zoom), ("Size", self.size_combo)):
            if label:
                self._texture_options.append(QLabel(label, self))
                bar.addWidget(self._texture_options[-1])
            self._texture_options.append(widget)
            bar.addWidget(widget)
        self.pages = QStackedWidget(self)
        self.pages.addWidget(self.scroll)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(bar)
        layout.addWidget(self.pages, 1)

        self.tabs.currentChanged.connect(self._tab_changed)
        self.tiling.toggled.connect(self._rebuild_image)
        self.zoom.currentIndexChanged.connect(self._show_image)
        self.size_combo.currentIndexChanged.connect(
            lambda: self.size_changed.emit(self.preview_size)
        )

    @property
    def preview_size(self) -> int:
        return int(self.size_combo.currentData())

    @property
    def channel(self) -> str:
        """The current tab's name: one of ``CHANNELS``, or ``TAB_3D``."""
        return self.tabs.tabText(self.tabs.currentIndex())

    def show_3d(self):
        """Switch to the 3D tab; returns its ``View3DPanel``."""
        self.tabs.setCurrentIndex(len(CHANNELS))
        return self.view3d

    def _tab_changed(self) -> None:
        is_3d = self.channel == TAB_3D
        if is_3d and self.view3d is None:
            # Made on demand: an OpenGL widget turns the whole window into a GL-composited one,
            # which an editor that never opens this tab does not need to pay for.
            self.view3d = View3DPanel(self._model, self.view_model)
            if self._grains is not None:
                self.view3d.view.set_grains(self._grains)
            self.pages.addWidget(self.view3d)
        for widget in self._texture_options:
            widget.setVisible(not is_3d)
        self.pages.setCurrentWidget(self.view3d if is_3d else self.scroll)
        if not is_3d:
            self._rebuild_image()

    def set_grains(self, textures: SandTextures) -> None:
        """A full tile for the 3D view (which uploads it the next time it draws)."""
        self._grains = textures
        if self.view3d is not None:
            self.view3d.view.set_grains(textures)

    def release_gl(self) -> None:
        """Release the 3D view's GL objects (before the window closes)."""
        if self.view3d is not None:
            self.view3d.view.cleanup()

    @property
    def textures(self) -> SandTextures | None:
        return self._textures

    def image(self) -> QImage:
        """The tile (or 2×2 tiles) of the current tab at texture resolution."""
        return self._image

    def show_textures(self, textures: SandTextures, final: bool) -> None:
        self._textures = textures
        # A low-resolution first tile is shown at the size the full one will have.
        self._target_size = textures.size if final else self.preview_size
        self._rebuild_image()

    def show_message(self, text: str) -> None:
        self._textures = None
        self._image = QImage()
        self.view.setPixmap(QPixmap())
        self.view.setText(text)

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        if ZOOMS[self.zoom.currentText()] is None:
            self._show_image()

    def _rebuild_image(self) -> None:
        if self._textures is None or self.channel not in CHANNELS:
            return
        rgb = channel_rgb(self._textures, self.channel)
        if self.tiling.isChecked():
            rgb = np.tile(rgb, (2, 2, 1))
        self._image = rgb_to_qimage(rgb)
        self._show_image()

    def _show_image(self) -> None:
        if self._image.isNull():
            return
        tiles = 2 if self.tiling.isChecked() else 1
        zoom = ZOOMS[self.zoom.currentText()]
        if zoom is None:
            available = self.scroll.viewport().size() - QSize(4, 4)
            side = max(1, min(available.width(), available.height()))
            shown = QSize(side, side)
        else:
            shown = QSize(self._target_size * tiles * zoom, self._target_size * tiles * zoom)
        self.scroll.setWidgetResizable(zoom is None)
        pixmap = QPixmap.fromImage(
            self._image.scaled(
                shown, Qt.AspectRatioMode.KeepAspectRatio, Qt.TransformationMode.FastTransformation
            )
        )
        self.view.setPixmap(pixmap)
        if zoom is not None:
            self.view.resize(pixmap.size())
