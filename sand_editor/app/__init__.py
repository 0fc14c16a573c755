"""The desktop editor: the only package that imports Qt.

Nothing else in ``sand_editor`` imports this package except the command line, lazily.
"""

from sand_editor.app._model import PresetModel
from sand_editor.app._run import missing_display, require_display, run_editor
from sand_editor.app._window import EditorWindow

__all__ = ["EditorWindow", "PresetModel", "missing_display", "require_display", "run_editor"]
