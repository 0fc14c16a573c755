"""The facets' lobe about a tilted grain, and what the slope moments make of it.

A clear grain's facets spread about the grain's own normal by a Beckmann distribution of the
facet roughness α: a lobe *rotated* with the grain. Seen in the slope space of the ground, a grain
of slope b (normal ∝ (b, 1)) then gives the facet slopes s the density

    K(s; b) = (1 + |b|²)^{5/2} / (1 + s·b)⁴ · exp(−tan²γ/α²) / (π α²),
    tan²γ = (|s − b|² + (s × b)²) / (1 + s·b)²,

(γ the angle between the facet normal and the grain's; Beckmann's D(m)·m_z⁴/cos θ_grain, which
integrates to 1 over slope space for every grain). The material's mipmaps hold the slopes'
moments, through which a footprint's density can only be a Gaussian of the grain slopes widened
by α²/2 — the lobe *sheared* to the grain's slope, exp(−|s − b|²/α²)/(π α²). The two agree for
smooth facets on flat grains and part as either tilts: on the shipped sands' ball caps, at the
half vectors a sunlit view sees, the rotated lobe holds 0–15 % more light (most for rough facets).

``lobe_correction`` measures that ratio over a tile's clear grains for a grid of facet
roughnesses and half-vector tilts; ``lobe_row`` takes the preset's roughness from it, and the
shader multiplies the moments' density by that row at the half vector's tilt
(``shaders/sand_glints.glsl``), so the far shading and the sparkles hold the rotated lobe's light.
"""

from __future__ import annotations

import numpy as np

# The table's axes: facet roughness, log-spaced from LOBE_ALPHAS[0] to the preset's largest, and
# the half vector's tilt from the ground's normal in degrees, 0 to LOBE_TILT_MAX_DEG. Smoother
# facets than the first row part from the sheared lobe by α² (both tend to the grains' own slope
# density as α → 0), so the shader scales that row's departure from 1 by (α/LOBE_ALPHAS[0])²
# below it; a sample of a tile's texels could not resolve lobes that narrow anyway.
LOBE_ALPHAS = np.geomspace(0.1, 1.0, 5)
LOBE_TILTS_DEG = np.linspace(0.0, 84.0, 13)
LOBE_TILT_MAX_DEG = float(LOBE_TILTS_DEG[-1])
# Half-vector azimuths averaged over (the grains' slopes are isotropic about the ground's normal).
_AZIMUTHS = 8
# Texels of the tile the ratio is measured on (a random sample of its clear texels).
_SAMPLES = 4096
# Far in the tails, where the tile holds almost no light at a half vector, both densities are
# vanishing and their ratio means nothing: each is taken with this share of the sheared
# density's largest over the tilts added, and the ratio kept within LOBE_RANGE.
_TAIL = 1e-2
LOBE_RANGE = (0.25, 4.0)


def rotated_density(s: np.ndarray, b: np.ndarray, alpha) -> np.ndarray:
    """Facet slope density at slopes ``s`` (…, 2) of grains of slopes ``b`` (…, 2), the lobe
    rotated with each grain: Beckmann of roughness ``alpha`` about the grain's normal."""
    sb = 1.0 + np.sum(s * b, axis=-1)
    cross = s[..., 0] * b[..., 1] - s[..., 1] * b[..., 0]
    d = s - b
    facing = sb > 1e-6
    safe = np.where(facing, sb, 1.0)
    tan2 = (np.sum(d * d, axis=-1) + cross * cross) / (safe * safe)
    jacobian = (1.0 + np.sum(b * b, axis=-1)) ** 2.5 / safe**4
    alpha2 = np.asarray(alpha, dtype=np.float64) ** 2
    density = jacobian * np.exp(-tan2 / alpha2) / (np.pi * alpha2)
    return np.where(facing, density, 0.0)


def sheared_density(s: np.ndarray, b: np.ndarray, alpha) -> np.ndarray:
    """The same facets as the slope moments see them: slopes N(b, α²/2·I)."""
    d = s - b
    alpha2 = np.asarray(alpha, dtype=np.float64) ** 2
    return np.exp(-np.sum(d * d, axis=-1) / alpha2) / (np.pi * alpha2)


def lobe_correction(slopes: np.ndarray, weights: np.ndarray, seed: int = 0) -> np.ndarray:
    """The rotated lobe's light over the sheared one's, for each (roughness, tilt) of the table.

    ``slopes`` (n, 2) are grain slopes and ``weights`` (n,) their clear weights (0 where not
    clear). For each facet roughness and half-vector tilt: the tile's w-weighted density of
    facet slopes at the half vector, rotated over sheared, summed over azimuths (so that
    azimuths where the tile holds more light count more). 1 where the tile has no clear grain.
    """
    slopes = np.asarray(slopes, dtype=np.float64).reshape(-1, 2)
    weights = np.asarray(weights, dtype=np.float64).reshape(-1)
    clear = (weights > 0.0) & np.isfinite(slopes).all(axis=-1)
    table = np.ones((LOBE_ALPHAS.size, LOBE_TILTS_DEG.size))
    if not clear.any():
        return table
    slopes, weights = slopes[clear], weights[clear]
    if slopes.shape[0] > _SAMPLES:
        pick = np.random.default_rng(seed).choice(slopes.shape[0], _SAMPLES, replace=False)
        slopes, weights = slopes[pick], weights[pick]
    azimuths = (np.arange(_AZIMUTHS) + 0.5) * (2.0 * np.pi / _AZIMUTHS)
    directions = np.stack([np.cos(azimuths), np.sin(azimuths)], axis=-1)
    alphas = LOBE_ALPHAS[:, None, None]  # (alphas, azimuths, texels)
    rotated = np.empty_like(table)
    sheared = np.empty_like(table)
    for j, tilt in enumerate(np.radians(LOBE_TILTS_DEG)):
        half = (np.tan(tilt) * directions)[:, None, :]  # (azimuths, 1, 2)
        rotated[:, j] = np.sum(weights * rotated_density(half, slopes[None], alphas), axis=(1, 2))
        sheared[:, j] = np.sum(weights * sheared_density(half, slopes[None], alphas), axis=(1, 2))
    floor = _TAIL * sheared.max(axis=1, keepdims=True)
    table = (rotated + floor) / (sheared + floor)
    return np.clip(table, *LOBE_RANGE)


def lobe_row(table: np.ndarray, alpha: float) -> np.ndarray:
    """The table's correction over the half-vector tilts for facet roughness ``alpha``: linear
    in log α between rows, and below the first row its departure from 1 scaled by
    (α/LOBE_ALPHAS[0])² (both lobes tend to the grains' own slopes as α → 0)."""
    logs = np.log(LOBE_ALPHAS)
    position = np.interp(np.log(max(alpha, LOBE_ALPHAS[0])), logs, np.arange(LOBE_ALPHAS.size))
    low = int(np.floor(position))
    high = min(low + 1, LOBE_ALPHAS.size - 1)
    row = table[low] + (table[high] - table[low]) * (position - low)
    smooth = min(alpha / LOBE_ALPHAS[0], 1.0) ** 2
    return 1.0 + (row - 1.0) * smooth
