"""A still drawn with k×k samples a pixel: where its samples lie in the pixel, and the light they
gather (``SandRenderer.render_still``, the editor's 3D view at rest)."""

from __future__ import annotations

import numpy as np

from sand_editor.colour import luminance

# The most samples a still's pixel may take on each axis: 8×8, the depth bench's truth.
MAX_STILL_SAMPLES = 8


def check_samples(samples) -> None:
    """A still's samples a pixel on each axis: a whole number from 1 to MAX_STILL_SAMPLES."""
    if isinstance(samples, bool) or not isinstance(samples, int):
        raise ValueError(f"samples must be a whole number, got {samples!r}")
    if not 1 <= samples <= MAX_STILL_SAMPLES:
        raise ValueError(
            f"samples {samples} is out of range; allowed 1 to {MAX_STILL_SAMPLES} on each axis"
        )


def sample_offsets(samples: int) -> list[tuple[float, float]]:
    """The samples' places in the pixel, (right, up) from its centre in pixels: the centres of
    a ``samples``×``samples`` grid over it, row by row."""
    check_samples(samples)
    steps = (np.arange(samples) + 0.5) / samples - 0.5
    return [(float(dx), float(dy)) for dy in steps for dx in steps]


def sample_camera(camera, samples: int, index: int, size: tuple[int, int]):
    """The camera of sample ``index`` of a still of ``size`` with ``samples`` a side: each pixel
    sees the point at that sample's place in it (with ``FrameRequest.footprint_scale`` of
    1/``samples``)."""
    dx, dy = sample_offsets(samples)[index]
    return camera.shifted(-dx, -dy, size)


class GatheredLight:
    """The light of a frame's samples summed per pixel, rows from the bottom as the scene
    target holds them: each sample's light, and the variance of luminance within it (its
    spread, tone.glsl's, times its luminance squared). ``scene`` gives the average as the scene
    target takes it: the light and the spread the samples hold within them."""

    def __init__(self, width: int, height: int) -> None:
        self.size = (width, height)
        self._light = np.zeros((height, width, 3))
        self._variance = np.zeros((height, width))
        self._count = np.zeros(height)

    def add(self, scene: np.ndarray, first_row: int = 0) -> None:
        """A sample's scene target (rows, width, 4: light and spread) over rows from
        ``first_row`` up."""
        rows = slice(first_row, first_row + scene.shape[0])
        light = scene[..., :3].astype(np.float64)
        self._light[rows] += light
        self._variance[rows] += scene[..., 3] * luminance(light) ** 2
        self._count[rows] += 1

    def forget(self, first_row: int, end_row: int) -> None:
        """Drop what those rows gathered (a new set of samples begins there)."""
        rows = slice(first_row, end_row)
        self._light[rows] = 0.0
        self._variance[rows] = 0.0
        self._count[rows] = 0

    def scene(self, first_row: int = 0, end_row: int | None = None) -> np.ndarray:
        """The average of those rows as half floats (rows, width, 4), ready for the target."""
        rows = slice(first_row, self.size[1] if end_row is None else end_row)
        count = np.maximum(self._count[rows], 1.0)[:, None]
        light = self._light[rows] / count[..., None]
        mean = luminance(light)
        variance = self._variance[rows] / count
        spread = np.divide(variance, mean**2, out=np.zeros_like(mean), where=mean > 0)
        spread = np.minimum(spread, np.finfo(np.float16).max)  # finite in the half floats
        return np.dstack([light, spread]).astype(np.float16)
