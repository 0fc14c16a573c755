"""How the 3D view keeps answering (Qt-free): while anything moves, frames are drawn at a
fraction of the widget's pixels, chosen so a frame takes about FRAME_BUDGET_MS; SETTLE_MS after
the last change the full-resolution frame is drawn in bands of rows, each through the matching
slice of the camera's frustum."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

FRAME_BUDGET_MS = 25.0
MIN_SCALE = 0.08
MIN_BAND_ROWS = 8
MAX_MOVING_SCALE = 0.75
SETTLE_MS = 300


def adapted_scale(frame_ms: float, scale: float) -> float:
    """The scale for the next moving frame, after one at ``scale`` took ``frame_ms``."""
    # Cost grows with the pixel count, the square of the scale; damped against jitter.
    wanted = scale * math.sqrt(FRAME_BUDGET_MS / max(frame_ms, 1e-3))
    wanted = 0.5 * scale + 0.5 * wanted
    return min(max(wanted, MIN_SCALE), MAX_MOVING_SCALE)


def band_camera(camera, first_row: int, end_row: int, height: int):
    """The camera whose frustum is rows [first_row, end_row) of ``camera``'s (rows from the
    bottom): clip y is stretched so that band fills the viewport."""
    bottom = 2.0 * first_row / height - 1.0
    top = 2.0 * end_row / height - 1.0
    stretch = np.eye(4)
    stretch[1, 1] = 2.0 / (top - bottom)
    stretch[1, 3] = -(top + bottom) / (top - bottom)
    projection = stretch @ camera.projection.astype(np.float64)
    return dataclasses.replace(camera, projection=projection.astype(np.float32))
