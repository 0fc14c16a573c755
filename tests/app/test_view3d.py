"""The 3D tab: the real renderer on the view's drawing thread, driven by its controls and the
preset model, shown in a real window."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtGui import QImage

from sand_editor.app import EditorWindow
from sand_editor.app._refinement import MIN_BAND_ROWS
from sand_editor.app._view3d import DISTANCE_STEPS, MAX_DISTANCE_M, MIN_DISTANCE_M
from sand_editor.render.modes import MODES
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import sky_at
from sand_editor.resources import bundled_preset

pytestmark = pytest.mark.qt

TIMEOUT_MS = 20_000
VIEW_SIZE = (160, 100)  # llvmpipe on a couple of cores: small frames keep each test quick


def pixels(image: QImage) -> np.ndarray:
    image = image.convertToFormat(QImage.Format.Format_RGB888)
    rows = np.frombuffer(image.constBits(), np.uint8).reshape(image.height(), -1)
    return rows[:, : image.width() * 3].reshape(image.height(), image.width(), 3).copy()


def open_3d(editor, qtbot):
    panel = editor.preview.show_3d()
    panel.view.setFixedSize(*VIEW_SIZE)
    view = panel.view
    qtbot.waitUntil(lambda: view.frames > 0 or view.error is not None, timeout=TIMEOUT_MS)
    assert panel.view.error is None, panel.view.error
    return panel


@pytest.fixture
def panel(window, qtbot):
    return open_3d(window, qtbot)


def frame(panel, qtbot) -> np.ndarray:
    """The view's full-resolution frame of its current settings, as the window shows it."""
    qtbot.waitUntil(lambda: panel.view.at_rest or panel.view.error is not None, timeout=TIMEOUT_MS)
    assert panel.view.error is None, panel.view.error
    image = pixels(panel.view.grab().toImage())
    assert panel.view.gl_error() == "GL_NO_ERROR"
    return image


def test_the_view_initialises_and_paints_the_desert(panel, qtbot):
    image = frame(panel, qtbot)
    assert image.shape[:2] == (VIEW_SIZE[1], VIEW_SIZE[0])
    assert image.max() > 40, "all black"
    assert image.reshape(-1, 3).std(axis=0).max() > 1.0, "a single flat colour"
    qtbot.waitUntil(lambda: " ms" in panel.status.text(), timeout=TIMEOUT_MS)
    assert panel.mode_combo.count() == len(MODES)


def test_night_is_darker_than_noon(panel, qtbot):
    panel.time_slider.setValue(12 * 60)
    assert panel.time_label.text() == "12:00"
    noon = frame(panel, qtbot)
    panel.time_slider.setValue(30)
    assert panel.time_label.text() == "00:30"
    assert panel.view.time_hours == pytest.approx(0.5)
    night = frame(panel, qtbot)
    assert night.mean() < 0.5 * noon.mean()


def test_shading_changes_keep_the_grains_and_generation_changes_replace_them(panel, qtbot):
    view = panel.view
    material = view.material
    uploads = view.grain_uploads
    frames = view.frames

    panel.model.edit("shading.clear_grains", 0.5)
    qtbot.waitUntil(lambda: view.frames > frames, timeout=TIMEOUT_MS)
    assert view.grain_uploads == uploads
    assert material.preset.shading.clear_grains == 0.5

    panel.model.edit("generation.seed", panel.model.preset.generation.seed + 1)
    qtbot.waitUntil(lambda: view.grain_uploads > uploads, timeout=TIMEOUT_MS)
    qtbot.waitUntil(lambda: view.material.preset == panel.model.preset, timeout=TIMEOUT_MS)
    assert view.grains_generation == panel.model.preset.generation
    assert view.gl_error() == "GL_NO_ERROR"
    # The texture preview shows the same tile the view took.
    qtbot.waitUntil(lambda: not panel.window().regenerator.busy, timeout=TIMEOUT_MS)
    assert panel.window().preview.textures.size == panel.window().preview.preview_size


def test_a_fixed_exposure_overrides_the_metered_one_and_auto_restores_it(panel, qtbot):
    panel.time_slider.setValue(12 * 60)
    metered = frame(panel, qtbot)
    panel.exposure.setValue(0.05)
    assert panel.view_model.state.exposure == 0.05 and panel.view.exposure == 0.05
    qtbot.waitUntil(lambda: panel.view.last_timings["exposure"] == 0.05, timeout=TIMEOUT_MS)
    dim = frame(panel, qtbot)
    assert dim.mean() < 0.5 * metered.mean()
    panel.exposure.setValue(0.0)
    assert panel.exposure.text() == "auto" and panel.view.exposure is None
    qtbot.waitUntil(lambda: panel.view.last_timings["exposure"] != 0.05, timeout=TIMEOUT_MS)
    # The view model shows a fixed exposure set elsewhere (the settings, the VR link).
    panel.view_model.update("test", exposure=2.0)
    assert panel.exposure.value() == 2.0


def test_blend_mode_changes_the_image(panel, qtbot):
    full = frame(panel, qtbot)
    panel.mode_combo.setCurrentText("blend")
    assert panel.view.mode == "blend"
    blend = frame(panel, qtbot)
    assert np.abs(blend.astype(int) - full.astype(int)).mean() > 5


def _drawn_at_once(panel) -> np.ndarray:
    """The view's frame drawn by its renderer as one frame (rows top-down, RGB)."""
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.request import FrameRequest
    from sand_editor.render.sky import sky_at

    view, (width, height) = panel.view, VIEW_SIZE
    exposure = view.last_timings["exposure"]

    def draw(ctx):
        terrain = view.renderer.terrain
        camera = camera_at_distance(
            view.distance_m, view.pitch_deg, width / height,
            ground_height=lambda x, z: float(terrain.height(x, z)), heading_deg=view.heading_deg,
        )  # fmt: skip
        request = FrameRequest(camera, sky_at(view.time_hours), view.mode, exposure=exposure)
        return view.renderer.render_to_array(width, height, request)

    return view.call_in_context(draw)


def test_a_still_in_bands_blooms_as_one_frame(panel, qtbot, monkeypatch):
    """A still's samples are drawn in bands, but the last band of each pass brings the whole
    frame, its gathered light resolved at once, so that bloom spreads across the bands' edges
    (a band's own bloom is cut at its edges, which smears a sparkle's glow sideways)."""
    import sand_editor.app._sand_view as sand_view

    monkeypatch.setattr(sand_view, "FRAME_BUDGET_MS", 1e-3)  # bands of MIN_BAND_ROWS rows
    panel.distance_spin.setValue(0.3)
    panel.samples.setCurrentIndex(panel.samples.findData(2))
    frame(panel, qtbot)
    bands = []
    panel.view.rendered.connect(lambda t: "sampled" in t and bands.append(t["rows"]))
    panel.view.changing()
    frame(panel, qtbot)
    height = VIEW_SIZE[1]
    one_pass = [(first, first + MIN_BAND_ROWS) for first in range(0, height, MIN_BAND_ROWS)]
    one_pass[-1] = (0, height)
    assert bands == one_pass * 4, bands


def test_the_resting_frame_drawn_in_bands_is_the_frame_drawn_at_once(panel, qtbot, monkeypatch):
    """The full-resolution frame is drawn in bands, but its last band brings the whole frame
    with the bands' light bloomed at once: pixel for pixel the frame drawn in one go at the
    bands' exposure. Bloomed band by band, a sparkle's glow was cut at each band's edges and
    smeared along them (here up to 91 levels off, 0.28 on average)."""
    import sand_editor.app._sand_view as sand_view

    monkeypatch.setattr(sand_view, "FRAME_BUDGET_MS", 1e-3)  # bands of MIN_BAND_ROWS rows
    size = (480, 300)  # wide enough for a sparkle's glow to reach across bands
    panel.view.setFixedSize(*size)
    panel.distance_spin.setValue(0.3)
    panel.pitch_slider.setValue(20)
    bands = []
    panel.view.rendered.connect(lambda t: t["scale"] == 1.0 and bands.append(t["rows"]))
    frame(panel, qtbot)
    one_pass = [(first, first + MIN_BAND_ROWS) for first in range(0, size[1], MIN_BAND_ROWS)]
    one_pass[-1] = (0, size[1])
    assert bands == one_pass, bands
    view, worker = panel.view, panel.view.gl
    params, exposure = view.view, view.last_timings["exposure"]

    def at_once(ctx):
        camera = worker.view_camera(params, size)
        request = FrameRequest(camera, sky_at(params.time_hours), params.mode, exposure=exposure)
        return worker.renderer.render_to_array(*size, request)

    whole = view.call_in_context(at_once)
    assert (whole > 250).any(), "no sparkle in view to bloom"
    difference = np.abs(view.full_frame[..., :3].astype(int) - whole.astype(int))
    # What remains is a rare pixel on a band's edge, shaded with a neighbour of its own band:
    # where the grains' relief has an edge, a last bit of the ray's position decides which
    # grain the pixel shows (two pixels of 144 000 here, 17 and 23 levels off).
    off = int((difference.max(axis=-1) >= 20).sum())
    assert difference.mean() < 0.02 and off <= 10, (difference.mean(), off, difference.max())


def test_samples_draw_the_resting_view_again_as_a_still(panel, qtbot):
    """2×2 samples: once the frame is at full resolution, four more passes, band by band, each
    showing the light gathered so far; the view is at rest when all four are in. Up close the
    still resolves the grains' outlines (other pixels), its light the frame's; one sample again
    draws the frame as before, and a change starts the samples over."""
    panel.distance_spin.setValue(0.3)
    panel.pitch_slider.setValue(20)
    one = frame(panel, qtbot)
    sampled = []
    panel.view.rendered.connect(lambda t: "sampled" in t and sampled.append(t["sampled"]))
    panel.samples.setCurrentIndex(panel.samples.findData(2))
    assert panel.view.samples == 2
    still = frame(panel, qtbot)
    assert sampled and sampled[-1] == 1.0 and sampled == sorted(sampled), sampled
    assert "2×2 samples: 100%" in panel.status.text()
    assert np.abs(still.astype(int) - one.astype(int)).mean() > 1.0
    assert still.mean() == pytest.approx(one.mean(), rel=0.05)
    panel.pitch_slider.setValue(25)  # a change: the samples begin again
    assert not panel.view.at_rest
    frame(panel, qtbot)
    assert sampled.count(1.0) == 2
    panel.samples.setCurrentIndex(panel.samples.findData(1))
    again = frame(panel, qtbot)
    assert panel.view.samples == 1 and "samples" not in panel.status.text()
    assert again.shape == one.shape
    with pytest.raises(ValueError, match="samples"):
        panel.view.set_samples(9)


@pytest.mark.parametrize("sphere", [False, True])
def test_both_ends_of_the_distance_range_render_cleanly(panel, sphere, qtbot):
    panel.sphere.setChecked(sphere)
    panel.distance_slider.setValue(0)
    assert panel.view.distance_m == pytest.approx(MIN_DISTANCE_M)
    assert panel.distance_spin.value() == pytest.approx(MIN_DISTANCE_M)
    near = frame(panel, qtbot)
    panel.distance_spin.setValue(MAX_DISTANCE_M)
    assert panel.distance_slider.value() == DISTANCE_STEPS
    far = frame(panel, qtbot)
    for image in (near, far):
        assert image.max() > 40
    assert panel.view.gl_error() == "GL_NO_ERROR"


def test_wheel_and_drag_move_the_camera(panel, qtbot):
    panel.view.zoomed.emit(2.0)
    assert panel.view.distance_m == pytest.approx(2.0, rel=1e-3)
    assert panel.distance_spin.value() == pytest.approx(2.0, rel=1e-3)
    view = panel.view
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(40, 40))
    qtbot.mouseMove(view, QPoint(60, 30))
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=QPoint(60, 30))
    assert view.heading_deg != 0.0
    assert view.pitch_deg < 45.0
    # The controls follow a drag a few times a second.
    qtbot.waitUntil(
        lambda: panel.heading_spin.value() == int(view.heading_deg) % 360, timeout=TIMEOUT_MS
    )
    assert panel.pitch_slider.value() == round(view.pitch_deg)


def test_a_running_day_advances_the_clock_only_while_shown(panel, qtbot):
    panel.time_slider.setValue(6 * 60)
    panel.day_speed.setValue(1.0)  # an hour a second
    assert panel.day_timer.isActive()
    qtbot.waitUntil(lambda: panel.view.time_hours > 6.05, timeout=5_000)
    qtbot.waitUntil(lambda: panel.time_slider.value() > 6 * 60, timeout=5_000)
    assert panel.time_label.text() != "06:00"
    panel.window().preview.tabs.setCurrentIndex(0)
    assert not panel.day_timer.isActive()
    panel.day_speed.setValue(0)


def test_closing_the_editor_releases_the_gl_resources(qtbot, default_preset):
    editor = EditorWindow(default_preset, source=bundled_preset("paper-default"))
    editor.show()
    qtbot.waitExposed(editor)
    panel = open_3d(editor, qtbot)
    frame(panel, qtbot)
    resources = panel.view.gl
    panel.view.orbited.emit(5.0, 0.0)  # closed with a frame in hand on the drawing thread
    assert panel.view._in_flight is not None

    editor.close()
    with qtbot.waitSignal(editor.destroyed, timeout=TIMEOUT_MS):
        editor.deleteLater()

    assert resources.release_error == "GL_NO_ERROR"
    assert resources.ctx is None and resources.renderer is None and resources.material is None
    assert not resources.running  # the drawing thread ended with the window
