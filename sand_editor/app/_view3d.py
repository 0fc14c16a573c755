"""The 3D tab: a ``SandView`` of the desert in the current preset's sand, with camera,
time-of-day and mode controls bound to the window's ``ViewModel`` (sand_editor.view)."""

from __future__ import annotations

import math

from PySide6.QtCore import QSignalBlocker, Qt, QTimer
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QSlider,
    QSpinBox,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from sand_editor.app._model import PresetModel
from sand_editor.app._sand_view import SandView
from sand_editor.render.modes import MODE_HELP, MODES
from sand_editor.view import (
    CLOCK,
    MAX_DAY_SPEED,
    MAX_DISTANCE_M,
    MIN_DISTANCE_M,
    REAL_TIME,
    ViewModel,
    ViewState,
    format_time,
)

CONTROLS_REFRESH_MS = 250
DISTANCE_STEPS = 1000  # slider positions across the log range
DAY_TICK_MS = 33
STILL_SAMPLES = (1, 2, 4)  # the samples a pixel on each axis the view offers at rest
# Changes whose controls are redrawn a few times a second rather than at once (a drag in the view,
# the running clock): each redraw of the controls costs a composition of the window.
_DRAG = "drag"
# What the view draws, by the view model's field names.
_VIEW_FIELDS = {
    "distance_m": "distance_m",
    "pitch_deg": "pitch_deg",
    "heading_deg": "heading_deg",
    "hours": "time_hours",
    "mode": "mode",
    "show_sphere": "show_sphere",
    "exposure": "exposure",
}


class View3DPanel(QWidget):
    """The 3D tab: a bar of controls above a ``SandView`` following the preset model."""

    def __init__(
        self, model: PresetModel, view_model: ViewModel | None = None, parent: QWidget | None = None
    ):
        super().__init__(parent)
        self.model = model
        self.view_model = view_model if view_model is not None else ViewModel()
        self.view = SandView(model.preset, self)
        self.view.setObjectName("view3d")

        self.distance_slider = QSlider(Qt.Orientation.Horizontal, objectName="view3d-distance")
        self.distance_slider.setRange(0, DISTANCE_STEPS)
        self.distance_slider.setToolTip("Distance from the camera to the sand, 1 mm to 100 m.")
        self.distance_spin = QDoubleSpinBox(objectName="view3d-distance-m")
        self.distance_spin.setRange(MIN_DISTANCE_M, MAX_DISTANCE_M)
        self.distance_spin.setDecimals(4)
        self.distance_spin.setSuffix(" m")
        self.distance_spin.setStepType(QDoubleSpinBox.StepType.AdaptiveDecimalStepType)
        self.pitch_slider = QSlider(Qt.Orientation.Horizontal, objectName="view3d-pitch")
        self.pitch_slider.setRange(1, 90)
        self.pitch_slider.setToolTip("Angle below the horizon, 1° (grazing) to 90° (down).")
        self.pitch_label = QLabel(objectName="view3d-pitch-label")
        self.heading_spin = QSpinBox(objectName="view3d-heading")
        self.heading_spin.setRange(0, 359)
        self.heading_spin.setWrapping(True)
        self.heading_spin.setSuffix("°")
        self.heading_spin.setToolTip("Compass direction of view: 0° north, 90° east.")
        self.time_slider = QSlider(Qt.Orientation.Horizontal, objectName="view3d-time")
        self.time_slider.setRange(0, 24 * 60)
        self.time_label = QLabel(objectName="view3d-time-label")
        self.day_speed = QDoubleSpinBox(objectName="view3d-day-speed")
        self.day_speed.setRange(0.0, MAX_DAY_SPEED)
        self.day_speed.setDecimals(4)
        self.day_speed.setStepType(QDoubleSpinBox.StepType.AdaptiveDecimalStepType)
        self.day_speed.setSpecialValueText("paused")
        self.day_speed.setSuffix(" h/s")
        self.day_speed.setToolTip(
            "Simulated hours per real second (as in VR); 0 pauses the day. "
            f"Real time is {REAL_TIME:.6f} h/s, a day a second 24 h/s."
        )
        self.mode_combo = QComboBox(objectName="view3d-mode")
        for mode in MODES:
            self.mode_combo.addItem(mode, mode)
            self.mode_combo.setItemData(
                self.mode_combo.count() - 1, MODE_HELP[mode], Qt.ItemDataRole.ToolTipRole
            )
        self.exposure = QDoubleSpinBox(objectName="view3d-exposure")
        self.exposure.setRange(0.0, 1000.0)
        self.exposure.setDecimals(2)
        self.exposure.setStepType(QDoubleSpinBox.StepType.AdaptiveDecimalStepType)
        self.exposure.setSpecialValueText("auto")
        self.exposure.setToolTip(
            "Exposure: auto adapts to the light and the scene as an eye does; a number fixes it."
        )
        self.samples = QComboBox(objectName="view3d-samples")
        for samples in STILL_SAMPLES:
            self.samples.addItem("1" if samples == 1 else f"{samples}×{samples}", samples)
        self.samples.setToolTip(
            "Samples a pixel once the view rests: the frame is drawn again that many times, each "
            "moved by a share of a pixel, and their light gathered (grains' outlines, relief "
            "edges and shadows resolved within the pixel; sparkles keep their light)."
        )
        self.sphere = QCheckBox("Sphere", objectName="view3d-sphere")
        self.sphere.setToolTip("Put a sand-covered sphere beside the point in view.")
        self.status = QLabel("—", objectName="view3d-status")

        grid = QGridLayout()
        grid.setContentsMargins(4, 2, 4, 2)
        row1 = (
            ("Distance", self.distance_slider, 3),
            ("", self.distance_spin, 0),
            ("Pitch", self.pitch_slider, 2),
            ("", self.pitch_label, 0),
            ("Heading", self.heading_spin, 0),
        )
        row2 = (
            ("Time", self.time_slider, 3),
            ("", self.time_label, 0),
            ("Day speed", self.day_speed, 0),
            ("Mode", self.mode_combo, 0),
            ("Exposure", self.exposure, 0),
            ("Samples", self.samples, 0),
            ("", self.sphere, 0),
        )
        for row, items in enumerate((row1, row2)):
            line = QHBoxLayout()
            for label, widget, stretch in items:
                if label:
                    line.addWidget(QLabel(label))
                line.addWidget(widget, stretch)
            grid.addLayout(line, row, 0)
        grid.addWidget(self.status, 2, 0)

        self.message = QLabel(objectName="view3d-message")
        self.message.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.message.setWordWrap(True)
        self.stack = QStackedWidget()
        self.stack.addWidget(self.view)
        self.stack.addWidget(self.message)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(grid)
        layout.addWidget(self.stack, 1)

        self._timings: dict | None = None
        self._controls_timer = QTimer(self, singleShot=True, interval=CONTROLS_REFRESH_MS)
        self._controls_timer.timeout.connect(self._refresh_controls)
        self.day_timer = QTimer(self, interval=DAY_TICK_MS)
        self.day_timer.timeout.connect(self._tick)

        self.distance_slider.valueChanged.connect(
            lambda step: self.set_distance(_distance_of_step(step))
        )
        self.distance_spin.valueChanged.connect(self.set_distance)
        self.pitch_slider.valueChanged.connect(lambda deg: self._set(pitch_deg=float(deg)))
        self.heading_spin.valueChanged.connect(lambda deg: self._set(heading_deg=float(deg)))
        self.time_slider.valueChanged.connect(lambda minutes: self.set_time(minutes / 60.0))
        self.day_speed.valueChanged.connect(self._day_speed_changed)
        self.mode_combo.currentIndexChanged.connect(
            lambda: self._set(mode=self.mode_combo.currentData())
        )
        self.sphere.toggled.connect(lambda on: self._set(show_sphere=on))
        self.samples.currentIndexChanged.connect(
            lambda: self.view.set_samples(self.samples.currentData())
        )
        self.exposure.valueChanged.connect(
            lambda value: self._set(exposure=float(value) if value > 0.0 else None)
        )
        self.view.orbited.connect(self._orbit)
        self.view.zoomed.connect(
            lambda factor: self.set_distance(self.view_model.state.distance_m * factor)
        )
        self.view.rendered.connect(self._frame_drawn)
        self.view.failed.connect(self.show_message)
        model.changed.connect(lambda preset, paths: self.view.set_preset(preset))

        self.view_model.connect(self._state_changed)
        everything = frozenset(ViewState.__dataclass_fields__)
        self._state_changed(self.view_model.state, everything, None)

    # -- controls ----------------------------------------------------------------------------------

    def _set(self, **changes) -> None:
        self.view_model.update(self, **changes)

    def set_distance(self, distance_m: float) -> None:
        self._set(distance_m=float(distance_m))

    def set_time(self, time_hours: float) -> None:
        """Set the clock (hours since midnight); the slider shows it to the minute."""
        self._set(hours=float(time_hours))

    def _day_speed_changed(self, speed: float) -> None:
        # 0 pauses the day and keeps its speed for the next play, as the VR panel does.
        if speed > 0:
            self._set(day_speed=float(speed), playing=True)
        else:
            self._set(playing=False)

    def _state_changed(self, state: ViewState, names: frozenset, source) -> None:
        """Show the view model's new state: in the view always, in the controls at once when
        someone else changed it (a drag or the running clock redraws them a few times a second)."""
        self.view.set_view(
            **{_VIEW_FIELDS[n]: getattr(state, n) for n in names if n in _VIEW_FIELDS}
        )
        if names & {"playing", "day_speed"}:
            with QSignalBlocker(self.day_speed):
                self.day_speed.setValue(state.day_speed if state.playing else 0.0)
            self._update_day_timer()
        if names & {"mode"}:
            with QSignalBlocker(self.mode_combo):
                self.mode_combo.setCurrentIndex(MODES.index(state.mode))
        if names & {"show_sphere"}:
            with QSignalBlocker(self.sphere):
                self.sphere.setChecked(state.show_sphere)
        if names & {"exposure"}:
            with QSignalBlocker(self.exposure):
                self.exposure.setValue(0.0 if state.exposure is None else state.exposure)
        if names & {"distance_m"}:
            with QSignalBlocker(self.distance_slider), QSignalBlocker(self.distance_spin):
                self.distance_slider.setValue(_step_of_distance(state.distance_m))
                self.distance_spin.setValue(state.distance_m)
        if source in (_DRAG, CLOCK):
            self._refresh_controls_soon()
        else:
            self._refresh_controls()

    def show_message(self, text: str) -> None:
        self.day_timer.stop()
        self.message.setText(text)
        self.stack.setCurrentWidget(self.message)
        self.status.setText("3D view unavailable")

    def _orbit(self, heading_delta: float, pitch_delta: float) -> None:
        state = self.view_model.state
        self.view_model.update(_DRAG, heading_deg=state.heading_deg + heading_delta,
                               pitch_deg=state.pitch_deg + pitch_delta)  # fmt: skip

    def _refresh_controls_soon(self) -> None:
        # Controls that follow a drag or the running clock are redrawn a few times a second,
        # not for every mouse move or tick: each redraw costs a composition of the window.
        if not self._controls_timer.isActive():
            self._controls_timer.start()

    def _refresh_controls(self) -> None:
        state = self.view_model.state
        for widget, value in (
            (self.heading_spin, int(state.heading_deg) % 360),
            (self.pitch_slider, round(state.pitch_deg)),
            (self.time_slider, round(state.hours * 60.0)),
        ):
            with QSignalBlocker(widget):
                widget.setValue(value)
        self.pitch_label.setText(f"{round(state.pitch_deg)}°")
        self.time_label.setText(format_time(state.hours))
        if self._timings is not None:
            self._show_timings(self._timings)

    def _frame_drawn(self, timings: dict) -> None:
        self._timings = timings
        if self.view.at_rest:
            self._refresh_controls()  # the final numbers, at once
        else:
            self._refresh_controls_soon()

    def _show_timings(self, timings: dict) -> None:
        if timings["refined"] == 0.0:
            frame = f"frame {timings['total_ms']:.0f} ms at {timings['scale']:.0%} resolution"
        elif timings["refined"] < 1.0:
            frame = f"refining to full resolution: {timings['refined']:.0%}"
        else:
            frame = f"full resolution in {timings['refine_ms']:.0f} ms ({timings['bands']} bands)"
        if "sampled" in timings:
            k = timings["samples"]
            frame += f" · {k}×{k} samples: {timings['sampled']:.0%}"
        self.status.setText(
            f"{self.view.mode} · {frame} · CPU sky {timings['sky_ms']:.1f}, "
            f"surface {timings['surface_ms']:.1f}, post {timings['post_ms']:.1f} ms · "
            f"exposure {timings['exposure']:.2f}"
        )

    # -- the running day ---------------------------------------------------------------------------

    def _update_day_timer(self) -> None:
        state = self.view_model.state
        running = state.playing and self.isVisible() and self.view.error is None
        if running and not self.day_timer.isActive():
            self.view_model.tick(source=CLOCK)  # the time the tab was hidden, at once
            self.day_timer.start()
        elif not running:
            self.day_timer.stop()

    def _tick(self) -> None:
        self.view_model.tick(source=CLOCK)

    def showEvent(self, event) -> None:
        super().showEvent(event)
        self._update_day_timer()

    def hideEvent(self, event) -> None:
        super().hideEvent(event)
        self.day_timer.stop()


def _step_of_distance(distance_m: float) -> int:
    span = math.log10(MAX_DISTANCE_M / MIN_DISTANCE_M)
    return round(math.log10(distance_m / MIN_DISTANCE_M) / span * DISTANCE_STEPS)


def _distance_of_step(step: int) -> float:
    span = math.log10(MAX_DISTANCE_M / MIN_DISTANCE_M)
    return MIN_DISTANCE_M * 10.0 ** (step / DISTANCE_STEPS * span)
