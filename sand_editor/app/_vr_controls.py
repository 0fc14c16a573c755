"""The editor window's way into VR: the "View in VR" button and menu, the viewer's state beside
it, what the editor says when the viewer cannot run, and the link's bindings to the preset model
and to the window's view model (time of day and mode, both ways, without echoes)."""

from __future__ import annotations

from PySide6.QtCore import QEvent, QObject, QTimer
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QApplication, QLabel, QMainWindow, QMessageBox, QPushButton

from sand_editor.app._vr import VrLink
from sand_editor.app._vr_exit import LOG_HEADING
from sand_editor.app._vr_grains import SharedTiles
from sand_editor.preset import Preset
from sand_editor.view import CLOCK, MODES, TIME_FIELDS, ViewState
from sand_editor.vr.link import (
    EXIT_INTERRUPTED,
    EXIT_NO_HEADSET,
    EXIT_NO_RUNTIME,
    EXIT_OK,
)

VR_SHORTCUT = "Ctrl+Shift+V"
START_TEXT = "View in VR"
STOP_TEXT = "Stop VR"
STATUS_MESSAGE_MS = 8000
# The one accented button of the tool bar: the way into the headset should be easy to find.
BUTTON_STYLE = (
    "QToolButton { font-weight: 600; padding: 3px 12px; border: 1px solid #b9854a;"
    " border-radius: 4px; background: #f6e7d2; }"
    " QToolButton:hover { background: #efd6b2; } QToolButton:pressed { background: #e4c393; }"
)
OFFER_DESKTOP = frozenset({EXIT_NO_RUNTIME, EXIT_NO_HEADSET})


class VrControls(QObject):
    """The editor window's VR button, menu and state label, and the link's bindings to the
    preset model and to the 3D view's time-of-day and mode controls.

    Parameters
    ----------
    window
        The editor window: its ``model``, ``preview`` (with the 3D panel once it exists), menu
        bar, tool bars and status bar are used.
    """

    def __init__(self, window: QMainWindow):
        super().__init__(window)
        self.window = window
        self.link = VrLink(self, SharedTiles(window.regenerator))
        self.message_box: QMessageBox | None = None
        self.desktop_button: QPushButton | None = None
        self._close_window_after = False
        self.view_model = window.view_model

        shortcut = QKeySequence(VR_SHORTCUT)
        self.action = QAction(START_TEXT, self, objectName="vr-action")
        self.action.setShortcut(shortcut)
        self.action.triggered.connect(self.toggle)
        self._start_tip = (
            "Show the sand you are editing in your VR headset, with your edits and the time "
            f"of day live ({shortcut.toString(QKeySequence.SequenceFormat.NativeText)})"
        )
        self.desktop_action = QAction("Desktop stereo preview", self, objectName="vr-desktop")
        self.desktop_action.setStatusTip("Both eyes side by side in a window, without a headset")
        self.desktop_action.triggered.connect(lambda: self.start(desktop=True))
        self.state_label = QLabel(objectName="vr-state")

        menu = window.menuBar().addMenu("&VR")
        menu.addActions([self.action, self.desktop_action])
        toolbar = window.addToolBar("VR")
        toolbar.setObjectName("vr-toolbar")
        toolbar.addAction(self.action)
        toolbar.addWidget(self.state_label)
        self.button = toolbar.widgetForAction(self.action)
        self.button.setObjectName("vr-button")
        self.button.setStyleSheet(BUTTON_STYLE)
        self.state_label.setStyleSheet("padding: 0 8px; color: #555555;")

        self.link.started.connect(self._show_state)
        self.link.ready.connect(self._on_ready)
        self.link.state.connect(self._show_state)
        self.link.applied.connect(self._on_applied)
        self.link.time.connect(self._remote_time)
        self.link.mode.connect(self._remote_mode)
        self.link.error.connect(self._on_error)
        self.link.finished.connect(self._on_finished)
        window.model.changed.connect(self._local_preset)
        self.view_model.connect(self._local_view_changed)
        app = QApplication.instance()
        if app is not None:
            app.aboutToQuit.connect(self.link.shutdown)
        window.installEventFilter(self)  # sees the window's close before the window does
        self._show_state()

    # -- starting and stopping ----------------------------------------------------------------

    def toggle(self) -> None:
        if self.link.running:
            self.link.stop()
            self._show_state()
        else:
            self.start()

    def start(self, desktop: bool = False) -> None:
        """Start the viewer on the preset as it is now (unsaved edits included)."""
        if self.link.running:
            return
        self._close_message()
        self.view_model.tick()  # the clock as it is now, if it runs while the 3D tab is hidden
        state = self.view_model.state
        scene = {"hours": state.hours, "mode": state.mode,
                 "day_speed": state.day_speed if state.playing else 0.0}  # fmt: skip
        self.link.start(self.window.model.preset, desktop=desktop, scene=scene)
        self._show_state()

    def eventFilter(self, watched: QObject, event: QEvent) -> bool:
        # Closing the window with the viewer running asks the viewer to quit first; the window
        # closes again (asking about unsaved changes as usual) once the viewer has exited.
        if watched is self.window and event.type() == QEvent.Type.Close and self.link.running:
            event.ignore()
            self._close_window_after = True
            self.link.stop()
            self._show_state()
            return True
        return super().eventFilter(watched, event)

    # -- what the button and label show -------------------------------------------------------

    def _show_state(self, *_args) -> None:
        link = self.link
        if not link.running:
            text, tip = "", self._start_tip
        elif link.stopping:
            text, tip = "Closing…", "Waiting for the VR viewer to close"
        elif not link.is_ready:
            text = "Starting desktop preview…" if link.desktop else "Starting…"
            tip = "Waiting for the viewer's first frame"
        elif not link.responding:
            text, tip = "Not responding", "The viewer has not shown the latest edit"
        else:
            info = link.ready_info
            where = "Desktop preview" if info.get("backend") == "desktop" else "Headset"
            system = info.get("system") or info.get("runtime") or ""
            text = " · ".join(part for part in (where, link.session_state) if part)
            tip = f"{where}: {system}" if system else where
        self.action.setText(STOP_TEXT if link.running else START_TEXT)
        self.action.setToolTip(tip if link.running else self._start_tip)
        self.action.setStatusTip(self.action.toolTip())
        self.desktop_action.setEnabled(not link.running)
        self.state_label.setText(text)

    def _on_ready(self, info: dict) -> None:
        views = info.get("views") or []
        size = f"{views[0].get('width')}×{views[0].get('height')} per eye" if views else ""
        self._status(f"VR viewer ready: {info.get('runtime', '')} {size}".strip())
        self._show_state()

    def _on_applied(self, seq: int, ms: float) -> None:
        self._status(f"VR: edit #{seq} on screen, {ms:.0f} ms after it arrived")
        self._show_state()

    def _on_error(self, message: str) -> None:
        self._status(f"VR: {message}")
        self._show_state()

    def _on_finished(self, status: int, message: str) -> None:
        self._show_state()
        if self._close_window_after:
            self._close_window_after = False
            QTimer.singleShot(0, self.window.close)
            return
        self._status("VR: " + message.split("\n", 1)[0])
        if status not in (EXIT_OK, EXIT_INTERRUPTED) or self.link.stop_reason is not None:
            self._show_message(status, message)

    def _show_message(self, status: int, message: str) -> None:
        self._close_message()
        text, _, details = message.partition(LOG_HEADING)
        box = QMessageBox(self.window)
        box.setObjectName("vr-message")
        box.setIcon(QMessageBox.Icon.Warning)
        box.setWindowTitle(
            {EXIT_NO_RUNTIME: "No OpenXR runtime", EXIT_NO_HEADSET: "No VR headset"}.get(
                status, "VR viewer stopped"
            )
        )
        if status not in OFFER_DESKTOP:  # those say what to do instead
            text += f"\n\nYour work in the editor is as it was; {START_TEXT} starts a new viewer."
        box.setText(text)
        if details:
            box.setInformativeText(LOG_HEADING.strip() + "\n" + details)
            box.setDetailedText("\n".join(self.link.stderr_lines))
        self.desktop_button = None
        if status in OFFER_DESKTOP:
            box.setInformativeText(
                "You can look at the sand in stereo without a headset: both eyes side by "
                "side in a window, with mouse-look and keyboard controls."
            )
            self.desktop_button = box.addButton(
                "Open desktop preview", QMessageBox.ButtonRole.AcceptRole
            )
            box.addButton(QMessageBox.StandardButton.Close)
        else:
            box.addButton(QMessageBox.StandardButton.Ok)
        box.buttonClicked.connect(self._message_answered)
        self.message_box = box
        box.open()  # window-modal, without a nested event loop

    def _message_answered(self, button) -> None:
        offered = self.desktop_button
        self.message_box = self.desktop_button = None
        if offered is not None and button is offered:
            self.start(desktop=True)

    def _close_message(self) -> None:
        if self.message_box is not None:
            box, self.message_box = self.message_box, None
            box.close()
            box.deleteLater()

    def _status(self, text: str) -> None:
        self.window.statusBar().showMessage(text, STATUS_MESSAGE_MS)

    # -- editor → viewer ----------------------------------------------------------------------

    def _local_preset(self, preset: Preset, _paths) -> None:
        if self.link.running:
            self.link.send_preset(preset)

    def _local_view_changed(self, state: ViewState, names: frozenset, source) -> None:
        # The viewer runs its own clock: only set times go to it, not the ticks of ours.
        if source is self or source == CLOCK or not self.link.running:
            return
        if names & TIME_FIELDS:
            self.link.send_time(hours=state.hours, day_speed=state.day_speed, playing=state.playing)
        if "mode" in names:
            self.link.send_mode(state.mode)

    # -- viewer → editor ----------------------------------------------------------------------

    def _remote_time(self, fields: dict) -> None:
        self.view_model.update(self, **fields)

    def _remote_mode(self, mode: str) -> None:
        if mode not in MODES:
            self._on_error(f"the viewer switched to an unknown mode {mode!r}")
            return
        self.view_model.update(self, mode=mode)
