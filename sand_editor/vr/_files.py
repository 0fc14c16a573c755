"""The viewer's screenshots: eye images read back and written atomically as one PNG."""

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


def read_pixels(target, viewport) -> np.ndarray:
    """(height, width, 3) uint8 of a framebuffer's viewport, rows top-down."""
    x, y, width, height = viewport
    data = target.read(viewport=(x, y, width, height), components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(height, width, 3)[::-1]


def save_side_by_side(images: list[np.ndarray], path: Path) -> None:
    """The eyes' images next to each other, a black line between, as one PNG."""
    height = max(image.shape[0] for image in images)
    gap = np.zeros((height, 4, 3), np.uint8)
    parts = []
    for image in images:
        if image.shape[0] < height:
            pad = np.zeros((height - image.shape[0], *image.shape[1:]), np.uint8)
            image = np.vstack([image, pad])
        parts.extend([image, gap])
    write_png(np.hstack(parts[:-1]), path)
