"""The viewer's screenshots: eye images read back and written atomically as one PNG."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from sand_editor.files import write_atomic
from sand_editor.vr.errors import GraphicsError


def write_png(pixels: np.ndarray, path: Path) -> None:
    """``pixels`` (height, width, 3) uint8, rows top-down, written through a temporary file
    renamed into place, so a reader never sees half a file."""
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(pixels)).save(buffer, format="PNG")
    write_atomic(path, buffer.getvalue(), make_folder=True)


def read_pixels(target, viewport) -> np.ndarray:
    """(height, width, 3) uint8 of a framebuffer's viewport, rows top-down.

    ``target`` is a framebuffer the viewer made (not the window's, ``ctx.screen``, which
    moderngl cannot read without a GL error). An error the read leaves is raised here, as a
    ``GraphicsError``, instead of by whichever GL call comes next.
    """
    x, y, width, height = viewport
    data = target.read(viewport=(x, y, width, height), components=3, alignment=1)
    error = target.ctx.error
    if error != "GL_NO_ERROR":
        raise GraphicsError(f"reading the eyes back for a screenshot failed: {error}")
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
