"""Atomic PNG writing for the viewer's screenshots."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image


def write_png(pixels: np.ndarray, path: Path) -> None:
    """``pixels`` (height, width, 3) uint8, rows top-down, written through a temporary file
    renamed into place, so a reader never sees half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle = tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.", delete=False)
    try:
        with handle:
            Image.fromarray(np.ascontiguousarray(pixels)).save(handle, format="PNG")
        os.chmod(handle.name, 0o644)
        os.replace(handle.name, path)
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)
        raise
