"""The generated grain textures as numpy arrays, and their statistics."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class SandTextures:
    """Grain textures of one tile; row y is texture v, column x is u.

    Attributes
    ----------
    albedo : (size, size, 3) float32, linear RGB.
    normal : (size, size, 3) float32, unit tangent-space normals (+z out of the surface).
    height : (size, size) float32 ≥ 0, the grain profile of the owning layer, 0 in gaps.
    glint : (size, size) float32 in [0, 1], the grain's glint value on the top layer, else 0.
    layer : (size, size) int8, the layer owning the pixel, −1 in gaps.
    grain_id : (size, size) uint32, an identifier of the owning grain within its layer.
    generation : the generation parameters that made these grains (None for grains of unknown
        origin, which a material refuses).
    average_albedo : (3,) float32, mean linear albedo of the tile.
    """

    albedo: np.ndarray
    normal: np.ndarray
    height: np.ndarray
    glint: np.ndarray
    layer: np.ndarray
    grain_id: np.ndarray
    generation: object = None
    average_albedo: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "average_albedo",
            self.albedo.mean(axis=(0, 1), dtype=np.float64).astype(np.float32),
        )

    @property
    def size(self) -> int:
        return int(self.albedo.shape[0])

    def statistics(self, layers: int) -> dict:
        """Coverage per layer, gap fraction and visible grain count, as fractions of pixels."""
        counts = np.bincount(self.layer.ravel().astype(np.int64) + 1, minlength=layers + 1)
        total = float(self.layer.size)
        owned = self.layer >= 0
        keys = (self.layer[owned].astype(np.uint64) << np.uint64(32)) | self.grain_id[owned]
        return {
            "coverage_per_layer": [float(c) / total for c in counts[1 : layers + 1]],
            "gap_fraction": float(counts[0]) / total,
            "grain_count": int(np.unique(keys).size),
            "top_layer_grain_count": int(np.unique(self.grain_id[self.layer == 0]).size),
        }
