"""Lifetimes: the editor closes without a traceback after the 3D tab was used."""

from __future__ import annotations

import textwrap

import pytest

from tests.app.conftest import run_python

pytestmark = pytest.mark.qt

CLOSE_AFTER_3D = textwrap.dedent(
    """
    import sys
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication
    from sand_editor.app import EditorWindow
    from sand_editor.preset import Preset

    app = QApplication(sys.argv[:1])
    window = EditorWindow(Preset())
    window.resize(480, 360)
    window.show()

    def close_after_frames():
        view = window.preview.view3d.view
        if view.frames >= 2 or view.error:
            print("frames", view.frames, "error", view.error, flush=True)
            window.close()
        else:
            QTimer.singleShot(50, close_after_frames)

    QTimer.singleShot(200, lambda: window.preview.show_3d())
    QTimer.singleShot(300, close_after_frames)
    QTimer.singleShot(60_000, lambda: app.exit(3))
    sys.exit(app.exec())
    """
)


def test_closing_after_the_3d_tab_was_used_prints_no_traceback():
    result = run_python("-c", CLOSE_AFTER_3D, timeout=90)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "error None" in result.stdout, result.stdout
    assert "Traceback" not in result.stderr, result.stderr[-3000:]
    assert "Error" not in result.stderr, result.stderr[-3000:]
