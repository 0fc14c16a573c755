"""``sand-editor PRESET --screenshot FILE --tab TAB``: the window, once everything is drawn."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from PySide6.QtCore import QObject, QTimer
from PySide6.QtWidgets import QApplication

from sand_editor.app._preview import CHANNELS, TAB_3D
from sand_editor.files import OutputError

TABS = {name.lower(): index for index, name in enumerate((*CHANNELS, TAB_3D))}
POLL_MS = 50
TIMEOUT_S = 300.0


class ScreenshotWhenReady(QObject):
    """Waits until the full-size tile is shown (and on the 3D tab, the full-resolution frame is
    complete), then saves the window to ``path`` and quits the application with 0, or with 1
    and a message on stderr when that cannot happen."""

    def __init__(self, window, path: Path, tab: str) -> None:
        super().__init__(window)
        if tab not in TABS:
            raise ValueError(f"unknown tab {tab!r}; allowed: {', '.join(TABS)}")
        self.window, self.path, self.tab = window, Path(path), tab
        self._deadline = time.monotonic() + TIMEOUT_S
        self._ready_polls = 0
        window.preview.tabs.setCurrentIndex(TABS[tab])
        self._timer = QTimer(self, interval=POLL_MS)
        self._timer.timeout.connect(self._poll)
        self._timer.start()

    def _ready(self) -> bool:
        window = self.window
        textures = window.preview.textures
        if window.regenerator.busy or textures is None:
            return False
        if textures.size != window.preview.preview_size:
            return False
        if self.tab == "3d":
            view = window.preview.view3d.view
            if view.error is not None:
                raise RuntimeError(view.error)
            return view.at_rest
        return True

    def _poll(self) -> None:
        try:
            ready = self._ready()
        except RuntimeError as error:
            return self._finish(1, f"cannot take the screenshot: {error}")
        if time.monotonic() > self._deadline:
            return self._finish(1, f"nothing to show after {TIMEOUT_S:.0f} s")
        # Two polls in a row, so the last frame has reached the window.
        self._ready_polls = self._ready_polls + 1 if ready else 0
        if self._ready_polls < 2:
            return
        try:
            self.window.write_screenshot(self.path)
        except OutputError as error:
            return self._finish(1, str(error))
        print(f"saved {self.path}")
        self._finish(0, None)

    def _finish(self, code: int, message: str | None) -> None:
        self._timer.stop()
        if message:
            print(f"sand-editor: {message}", file=sys.stderr)
        self.window.model.undo_stack.setClean()
        self.window.close()
        QApplication.instance().exit(code)
