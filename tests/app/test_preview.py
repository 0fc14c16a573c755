"""Live preview: regenerates on generation changes only, debounced, with tiling and zoom."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtGui import QImage

from sand_editor.app._preview import CHANNELS, LAYER_PALETTE
from sand_editor.generator import generate

pytestmark = pytest.mark.qt

TIMEOUT_MS = 10_000


def pixels(image: QImage) -> np.ndarray:
    image = image.convertToFormat(QImage.Format.Format_RGB888)
    rows = np.frombuffer(image.constBits(), np.uint8).reshape(image.height(), -1)
    return rows[:, : image.width() * 3].reshape(image.height(), image.width(), 3).copy()


def test_generation_change_regenerates_a_different_preview(window, qtbot):
    before = pixels(window.preview.image())
    generations = window.regenerator.generations

    with qtbot.waitSignal(window.regenerator.finished, timeout=TIMEOUT_MS):
        window.model.edit("generation.threshold", 0.5)

    after = pixels(window.preview.image())
    assert window.regenerator.generations == generations + 1
    assert after.shape == before.shape
    assert np.mean(np.any(after != before, axis=2)) > 0.05


def test_shading_change_does_not_regenerate(window, qtbot):
    generations = window.regenerator.generations
    textures = window.preview.textures

    window.model.edit("shading.clear_grains", 0.5)
    qtbot.wait(300)  # several debounce intervals

    assert window.model.preset.shading.clear_grains == 0.5
    assert not window.regenerator.busy
    assert window.regenerator.generations == generations
    assert window.preview.textures is textures


def test_a_burst_of_changes_generates_once_with_the_last_value(window, qtbot):
    generations = window.regenerator.generations
    with qtbot.waitSignal(window.regenerator.finished, timeout=TIMEOUT_MS) as finished:
        for threshold in (0.31, 0.32, 0.33, 0.34, 0.35):
            window.model.edit("generation.threshold", threshold, gesture=True)
            qtbot.wait(10)
    qtbot.wait(200)

    assert window.regenerator.generations == generations + 1
    assert window.model.preset.generation.threshold == 0.35
    expected = generate(window.model.preset, window.preview.preview_size)
    assert np.array_equal(finished.args[0].albedo, expected.albedo)


def test_a_newer_change_cancels_the_running_generation(window, qtbot):
    window.model.edit("generation.seed", 1)
    qtbot.waitUntil(lambda: window.regenerator.running, timeout=TIMEOUT_MS)
    finished = []
    window.regenerator.finished.connect(lambda textures, seconds: finished.append(textures))

    window.model.edit("generation.seed", 2)
    qtbot.waitUntil(lambda: bool(finished) and not window.regenerator.busy, timeout=TIMEOUT_MS)
    qtbot.wait(100)

    assert len(finished) == 1
    expected = generate(window.model.preset, window.preview.preview_size)
    assert np.array_equal(finished[0].albedo, expected.albedo)


def test_each_tab_shows_its_own_map(window):
    images = []
    for index, channel in enumerate(CHANNELS):
        window.preview.tabs.setCurrentIndex(index)
        assert window.preview.channel == channel
        images.append(pixels(window.preview.image()))
    for i in range(len(images)):
        for j in range(i + 1, len(images)):
            assert not np.array_equal(images[i], images[j]), (CHANNELS[i], CHANNELS[j])
    layers = images[CHANNELS.index("Layers")]
    expected = LAYER_PALETTE[window.preview.textures.layer.astype(int) + 1]
    assert np.array_equal(layers, expected)


def test_tiling_shows_two_by_two_tiles_and_zoom_is_nearest_neighbour(window):
    size = window.preview.preview_size
    window.preview.tiling.setChecked(True)
    tiled = pixels(window.preview.image())
    assert tiled.shape[:2] == (2 * size, 2 * size)
    assert np.array_equal(tiled[:size, :size], tiled[size:, size:])

    window.preview.zoom.setCurrentText("2:1")
    shown = pixels(window.preview.view.pixmap().toImage())
    assert shown.shape[:2] == (4 * size, 4 * size)
    # Nearest neighbour: every texel becomes a uniform 2×2 block.
    for dy, dx in ((0, 1), (1, 0), (1, 1)):
        assert np.array_equal(shown[dy::2, dx::2], shown[::2, ::2])
    # The pixmap has the screen's depth (16 bits under the default Xvfb), hence the tolerance.
    assert np.abs(shown[::2, ::2].astype(int) - tiled).max() <= 8


def test_preview_size_combo_regenerates_at_that_size(window, qtbot):
    with qtbot.waitSignal(window.regenerator.finished, timeout=TIMEOUT_MS) as finished:
        window.preview.size_combo.setCurrentIndex(0)
    assert finished.args[0].size == 256
    assert window.preview.image().width() == 256


def test_status_bar_reports_time_and_grain_statistics(window):
    text = window.statistics_label.text()
    assert text.startswith(f"{window.preview.preview_size}×{window.preview.preview_size} in ")
    assert "top layer" in text and "gaps" in text and "grains" in text


def test_window_opens_on_the_default_preset_with_a_preview(window, tmp_path):
    assert window.model.preset.name == "paper-default"
    assert window.windowTitle().startswith("paper-default — ")
    assert not window.isWindowModified()

    shot = tmp_path / "editor.png"
    assert window.grab().save(str(shot))
    screenshot = pixels(QImage(str(shot)))
    assert screenshot.std() > 20
    view = window.preview.view
    corner = view.mapTo(window, view.rect().center())
    middle = screenshot[corner.y() - 50 : corner.y() + 50, corner.x() - 50 : corner.x() + 50]
    # Sand, not an empty widget: dark and light grains where the preview sits (the default
    # Xvfb screen has 16-bit colour, so few distinct values survive).
    assert len(np.unique(middle.reshape(-1, 3), axis=0)) > 10
    assert middle.min() < 100 and middle.max() > 200
