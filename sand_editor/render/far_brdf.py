"""The far-field diffuse BRDF of ``shaders/sand_far.glsl`` and ``sand_surface.glsl`` in numpy:
d'Eon's (2021) half space of Lambertian spheres, the subsurface blend and the light through
grain edges, on a flat macro surface.

The five normals that stand a footprint's grain normals for hold their mean and variance, not
the shape of their spread: over a footprint of whole grains their light strays from the grains'
own by up to 15 % (more at grazing lights). :func:`five_normals_correction` measures it from the
grains' tilts (:func:`grain_tilts`); the far range, and the close range as its footprint grows
to whole grains, take it (``shaders/sand_surface.glsl``'s ``diffuse_correction``).

What a program with only a Lambertian base colour (glTF, the engines) needs is the albedo that
reflects the same light: :func:`lambert_equivalent_albedo`. A half space of grains reflects less
than a Lambertian surface of the grains' albedo (light enters between them and is absorbed on
the way), and more towards the sun than away from it; the first carries over as a darker base
colour, the second does not.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sand_editor.preset import Preset

# Quadrature of the double integral over the light's and the eye's hemispheres.
_LIGHT_STEPS = 8
_EYE_STEPS = 8
# A grain side seen edge-on fades out over this band of n·v, and a shading normal is bent
# towards the eye to at least this n·v.
FACING_BAND = 0.15
MIN_FACING = 0.05
# filtered_diffuse_light's five normals: the centre's weight, and how far the others stand out
# (the variance the five hold is the footprint's).
DIFFUSE_CENTRE = 0.2
DIFFUSE_RING = math.sqrt(2.0 / (1.0 - DIFFUSE_CENTRE))
# The five normals' slopes reach at most this squared length (a normal 3° above its horizon).
MAX_SLOPE2 = 0.998
# The grains' tilts: bands of the normal's cosine to the surface's, and the azimuths each is
# taken at (the grains are the same in every direction).
TILT_BANDS = 32
TILT_AZIMUTHS = 24
# The five normals' correction is bounded: where they see almost none of a grazing light,
# their ratio to the grains' light says little.
CORRECTION_RANGE = (0.25, 4.0)
# Light through grain edges: a lobe around the light's way on, this sharp at no roughness.
TRANSMISSION_SHARPEST = 16.0
# d'Eon's (2021) fitted coefficients: the albedo mapping (Python alone: per material) ...
_C_POWER, _C_DENOMINATOR, _C_DENOMINATOR_POWER = 2.73556, 0.184096, 2.48423
_FLOOR_SCALE, _FLOOR_POWER = 1.94208, 1.85432
# ... and the BRDF's own, which the shaders take from here.
SPREAD_SCALE, SPREAD_OFFSET = 4.50996, 0.113706
C_OFFSET = 0.249978
SINGLE_WEIGHT, MULTIPLE_WEIGHT = 0.995917, 0.0684744
# The mean square of the ripple profile's slope (sand_far.glsl's ripples_at, in units of its
# steepest) against its asymmetry s: 0.5 (1 + s² (A + B s)) / (1 + s)², fitted to
# ripple_mean_square over 0 ≤ s ≤ 1.
RIPPLE_MEAN_SQUARE_FIT = (0.195, 0.19)
# The least deviation of slope the ripples too fine for a pixel hand to the light as tilts
# (sand_far.glsl): tilts of a smaller deviation σ change the light by under σ²/2.
RIPPLE_UNRESOLVED_LEAST = 0.05
# Ripple strength 1 means slopes this many times the detail map's (sand_far.glsl).
RIPPLE_SLOPE_GAIN = 8.0
# The ripple profile's asymmetry on gentle ground and on steep ground (sand_far.glsl).
RIPPLE_SHARPNESS = 0.5
RIPPLE_STEEP_SHARPNESS = 0.9
# The ripples too fine for a pixel tilt its diffuse light at three slopes of equal share: each
# third of the profile's slope distribution, at its mean angle (ripple_tilt_slopes). The
# shaders take each third's mean angle by Gauss–Legendre over its quantiles, at this many
# points of it (a vec4), whose slopes (in units of the steepest) are quadratics in the
# asymmetry (ripple_quantile_fit); the glints' light, sharper in the slope, at all twelve.
RIPPLE_QUANTILE_POINTS = 4
# Phases a period of the profile is sampled at for its slope distribution (a multiple of 3).
_SLOPE_STEPS = 3 << 13
# What shaders/sand_surface.glsl and sand_far.glsl are compiled with: these facts live here.
SHADER_DEFINES = {
    name: repr(float(value))
    for name, value in {
        "FACING_BAND": FACING_BAND,
        "MIN_FACING": MIN_FACING,
        "DIFFUSE_CENTRE": DIFFUSE_CENTRE,
        "DIFFUSE_RING": DIFFUSE_RING,
        "MAX_SLOPE2": MAX_SLOPE2,
        "TRANSMISSION_SHARPEST": TRANSMISSION_SHARPEST,
        "DEON_SPREAD_SCALE": SPREAD_SCALE,
        "DEON_SPREAD_OFFSET": SPREAD_OFFSET,
        "DEON_C_OFFSET": C_OFFSET,
        "DEON_SINGLE": SINGLE_WEIGHT,
        "DEON_MULTIPLE": MULTIPLE_WEIGHT,
        "RIPPLE_MEAN_SQUARE_A": RIPPLE_MEAN_SQUARE_FIT[0],
        "RIPPLE_MEAN_SQUARE_B": RIPPLE_MEAN_SQUARE_FIT[1],
        "RIPPLE_UNRESOLVED_LEAST": RIPPLE_UNRESOLVED_LEAST,
        "RIPPLE_SLOPE_GAIN": RIPPLE_SLOPE_GAIN,
        "RIPPLE_SHARPNESS": RIPPLE_SHARPNESS,
        "RIPPLE_STEEP_SHARPNESS": RIPPLE_STEEP_SHARPNESS,
    }.items()
}


def ripple_slope(phase, sharp):
    """The ripple profile's slope at ``phase`` (radians) for asymmetry ``sharp``, in units of
    its steepest (sand_far.glsl's ripples_at): the height sin(t + s sin t) differentiated."""
    phase = np.asarray(phase, dtype=np.float64)
    return np.cos(phase + sharp * np.sin(phase)) * (1.0 + sharp * np.cos(phase)) / (1.0 + sharp)


def ripple_slopes(sharp) -> np.ndarray:
    """The profile's slopes over a period, at _SLOPE_STEPS evenly spaced phases (the midpoints
    of as many equal steps)."""
    phase = 2.0 * np.pi * (np.arange(_SLOPE_STEPS) + 0.5) / _SLOPE_STEPS
    return ripple_slope(phase, sharp)


def ripple_mean_square(sharp) -> float:
    """The mean square of the ripple profile's slope over a period (exact for its harmonics
    below _SLOPE_STEPS)."""
    return float(np.mean(ripple_slopes(sharp) ** 2))


def ripple_mean_square_fit(sharp):
    """The shaders' fit of ripple_mean_square (RIPPLE_MEAN_SQUARE_FIT)."""
    a, b = RIPPLE_MEAN_SQUARE_FIT
    sharp = np.asarray(sharp, dtype=np.float64)
    return 0.5 * (1.0 + sharp**2 * (a + b * sharp)) / (1.0 + sharp) ** 2


def _ripple_slopes_sorted(sharp) -> np.ndarray:
    """The profile's slopes over a period, sorted: its slope distribution's quantiles at
    (i + ½) / _SLOPE_STEPS."""
    return np.sort(ripple_slopes(sharp))


def ripple_tilt_slopes(steepest, sharp) -> np.ndarray:
    """The three slopes the ripples too fine for a pixel tilt it at, for a profile of asymmetry
    ``sharp`` whose steepest slope is ``steepest``: the mean angle of each third of its slopes
    (sorted), as a slope. Each third stands for a third of the ripples' light: a rule that holds
    the profile's skew (its lee is short and steep, its windward side long and gentle) and, as
    angles, the light of slopes too steep for a mean of slopes to hold."""
    angles = np.arctan(steepest * _ripple_slopes_sorted(sharp))
    return np.tan(angles.reshape(3, -1).mean(axis=1))


def _quantile_points() -> tuple[np.ndarray, np.ndarray]:
    """The Gauss–Legendre points (3, RIPPLE_QUANTILE_POINTS) over each third of the quantiles,
    and their weights, summing to one."""
    x, w = np.polynomial.legendre.leggauss(RIPPLE_QUANTILE_POINTS)
    points = (np.arange(3)[:, None] + 0.5 * (x[None, :] + 1.0)) / 3.0
    return points, 0.5 * w


@functools.cache
def ripple_quantile_fit() -> np.ndarray:
    """The shaders' ripple_quantiles: the profile's slopes at each third's Gauss–Legendre
    quantiles as quadratics c0 + c1 s + c2 s² in its asymmetry s over the shipped range
    (RIPPLE_SHARPNESS to RIPPLE_STEEP_SHARPNESS); shape (3 coefficients, 3 thirds, points).
    Fitted once (read-only)."""
    points, _ = _quantile_points()
    sharp = np.linspace(RIPPLE_SHARPNESS, RIPPLE_STEEP_SHARPNESS, 17)
    at = (np.arange(_SLOPE_STEPS) + 0.5) / _SLOPE_STEPS
    slopes = np.array([np.interp(points, at, _ripple_slopes_sorted(s)) for s in sharp])
    coefficients = np.polynomial.polynomial.polyfit(sharp, slopes.reshape(sharp.size, -1), 2)
    coefficients = coefficients.reshape(3, 3, RIPPLE_QUANTILE_POINTS)
    coefficients.setflags(write=False)
    return coefficients


def ripple_tilt_slopes_fit(steepest, sharp) -> np.ndarray:
    """The shaders' ripple_tilt_slopes (sand_surface.glsl's ripple_nodes), from the fit."""
    c = ripple_quantile_fit()
    _, weights = _quantile_points()
    quantiles = c[0] + sharp * (c[1] + sharp * c[2])
    return np.tan((weights * np.arctan(steepest * quantiles)).sum(axis=1))


def _vec4(values) -> str:
    return "vec4({})".format(", ".join(repr(float(x)) for x in values))


def _quantile_defines() -> dict[str, str]:
    c = ripple_quantile_fit()
    _, weights = _quantile_points()
    defines = {"RIPPLE_QUANTILE_WEIGHTS": _vec4(weights)}
    for third in range(3):
        for power in range(3):
            defines[f"RIPPLE_QUANTILES_{third}{power}"] = _vec4(c[power, third])
    return defines


SHADER_DEFINES.update(_quantile_defines())


def sphere_albedo_terms(kd):
    """What d'Eon's (2021) Lambertian-sphere BRDF takes of a diffuse albedo alone: the
    particles' single-scattering albedo c and the multiple-scattering floor."""
    c = (1.0 - (1.0 - kd) ** _C_POWER) / (1.0 - _C_DENOMINATOR * (1.0 - kd) ** _C_DENOMINATOR_POWER)
    return c, (_FLOOR_SCALE * kd) ** _FLOOR_POWER


def sphere_brdf(kd, ui, uo, cos_io):
    """d'Eon's fitted BRDF at albedo ``kd`` for the cosines of light (``ui``) and eye (``uo``)
    to the normal and between them (``cos_io``); broadcasts, 0 below either horizon."""
    kd, ui, uo, cos_io = (np.asarray(x, dtype=np.float64) for x in (kd, ui, uo, cos_io))
    c, floor = sphere_albedo_terms(kd)
    u = np.clip(-cos_io, -1.0, 1.0)
    phase = 2.0 * (np.sqrt(np.maximum(1.0 - u * u, 0.0)) - u * np.arccos(u)) / (3.0 * np.pi**2)
    single = c * phase / np.maximum(ui + uo, 1e-4)
    s = np.sqrt(np.maximum((1.0 - ui * ui) * (1.0 - uo * uo), 0.0))
    s_safe = np.maximum(s, 1e-5)
    cos_phi = np.where(s > 1e-5, np.clip((cos_io - ui * uo) / s_safe, -1.0, 1.0), 1.0)
    spread = (np.arccos(cos_phi) + np.sqrt(np.maximum(ui * uo, 0.0))) / (
        SPREAD_SCALE * (np.arccos(np.minimum(s_safe, 1.0)) / s_safe + SPREAD_OFFSET)
    )
    multiple = spread * (c - C_OFFSET) + floor
    brdf = np.maximum(SINGLE_WEIGHT * single + MULTIPLE_WEIGHT * multiple, 0.0)
    return np.where((ui > 0.0) & (uo > 0.0), brdf, 0.0)


def _smoothstep(edge0: float, edge1: float, x):
    t = np.clip((x - edge0) / (edge1 - edge0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def moment_normals(moments, eye) -> tuple[np.ndarray, np.ndarray]:
    """The shading normals ``filtered_diffuse_light`` stands the grains' normals for: the mean
    normal and four more holding the normal moments' variance along the eye's azimuth and across
    it, with their weights. ``moments`` is (mean nx, mean ny, mean nx², mean ny²); ``eye``
    (..., 3) unit directions, +z up. Returns normals (..., 5, 3) and weights (5,)."""
    mx, my, sx, sy = (float(v) for v in moments)
    mean = np.array([mx, my])
    variance = np.maximum(np.array([sx, sy]) - mean * mean, 0.0)
    eye = np.asarray(eye, dtype=np.float64)
    towards = eye[..., :2]
    reach = np.linalg.norm(towards, axis=-1, keepdims=True)
    along = np.where(reach > 1e-5, towards / np.maximum(reach, 1e-12), np.array([1.0, 0.0]))
    across = np.stack([-along[..., 1], along[..., 0]], axis=-1)
    spread_along = along * (DIFFUSE_RING * np.sqrt(np.sum(along * along * variance, -1)))[..., None]
    spread_across = (
        across * (DIFFUSE_RING * np.sqrt(np.sum(across * across * variance, -1)))[..., None]
    )
    m = np.broadcast_to(mean, along.shape)
    points = np.stack(
        [m, m + spread_along, m - spread_along, m + spread_across, m - spread_across], axis=-2
    )
    length2 = np.sum(points * points, axis=-1, keepdims=True)
    limited = points * np.sqrt(MAX_SLOPE2 / np.maximum(length2, 1e-12))
    points = np.where(length2 > MAX_SLOPE2, limited, points)
    z = np.sqrt(np.maximum(1.0 - np.sum(points * points, axis=-1, keepdims=True), 0.0))
    weights = np.array([DIFFUSE_CENTRE] + [0.25 * (1.0 - DIFFUSE_CENTRE)] * 4)
    return np.concatenate([points, z], axis=-1), weights


def grain_tilts(normal_xy: np.ndarray) -> np.ndarray:
    """The grains' normals in TILT_BANDS equal bands of their cosine to the surface's normal,
    from every texel's nx, ny (..., 2): per band (TILT_BANDS, 2) the share of the normals in it
    and their mean cosine (a band's middle where it holds none), so that a flat tile's normals
    are exactly upright."""
    xy = np.asarray(normal_xy, dtype=np.float32).reshape(-1, 2)
    cosine = np.sqrt(np.clip(1.0 - xy[:, 0] * xy[:, 0] - xy[:, 1] * xy[:, 1], 0.0, 1.0))
    band = np.minimum((cosine * TILT_BANDS).astype(np.int64), TILT_BANDS - 1)
    counts = np.bincount(band, minlength=TILT_BANDS).astype(np.float64)
    sums = np.bincount(band, weights=cosine, minlength=TILT_BANDS)
    middle = (np.arange(TILT_BANDS) + 0.5) / TILT_BANDS
    mean = np.where(counts > 0, sums / np.maximum(counts, 1.0), middle)
    return np.stack([counts / max(float(counts.sum()), 1.0), mean], axis=-1)


def _facing(n, eye) -> tuple[np.ndarray, np.ndarray]:
    """For normals ``n`` (..., k, 3) and eyes ``eye`` (..., 3): the share the eye sees of each
    (fading over FACING_BAND of n·v) and the normal it is shaded with (bent to MIN_FACING)."""
    e = eye[..., None, :]
    facing = np.sum(n * e, axis=-1)
    seen = _smoothstep(-FACING_BAND, FACING_BAND, facing)
    bent = n + np.maximum(MIN_FACING - facing, 0.0)[..., None] * e
    return seen, bent / np.linalg.norm(bent, axis=-1, keepdims=True)


def _seen_light(n, light, eye) -> np.ndarray:
    """The diffuse light's shape on unit normals ``n`` (k, 3) for eyes ``eye`` (..., 3), as
    (..., k): the share the eye sees of each times the light's cosine on its shading normal,
    that of :func:`_facing` without forming it (n + b·e has length √(1 + 2b·n·e + b²))."""
    facing = eye @ n.T
    seen = _smoothstep(-FACING_BAND, FACING_BAND, facing)
    bend = np.maximum(MIN_FACING - facing, 0.0)
    towards_light = (n @ light + bend * (eye @ light)[..., None]) / np.sqrt(
        1.0 + 2.0 * bend * facing + bend * bend
    )
    return seen * np.maximum(towards_light, 0.0)


def five_normals_correction(tilts, moments, light, eye) -> np.ndarray:
    """What the five normals' diffuse light (:func:`moment_normals` of the tile's ``moments``)
    misses of the grains' own, whose tilts are ``tilts`` (:func:`grain_tilts`, each band's
    normals at its mean cosine, TILT_AZIMUTHS azimuths around): the ratio of
    the grains' light to the five's, for a ``light`` (3,) and eyes ``eye`` (..., 3), unit, +z
    up; 1 where the light is below the horizon."""
    light = np.asarray(light, dtype=np.float64)
    eye = np.asarray(eye, dtype=np.float64)
    if light[2] <= 0.0:
        return np.ones(eye.shape[:-1])
    tilts = np.asarray(tilts, dtype=np.float64)
    azimuth = (np.arange(TILT_AZIMUTHS) + 0.5) / TILT_AZIMUTHS * 2.0 * np.pi
    c, a = np.meshgrid(np.clip(tilts[:, 1], 0.0, 1.0), azimuth, indexing="ij")
    s = np.sqrt(1.0 - c * c)
    grains = np.stack([s * np.cos(a), s * np.sin(a), c], axis=-1).reshape(-1, 3)
    shares = np.repeat(tilts[:, 0] / TILT_AZIMUTHS, TILT_AZIMUTHS)
    exact = _seen_light(grains, light, eye) @ shares
    n, weights = moment_normals(moments, eye)
    seen, bent = _facing(n, eye)
    five = np.sum(seen * np.maximum(bent @ light, 0.0) * weights, axis=-1)
    ratio = np.where(five > 1e-6, exact / np.maximum(five, 1e-6), 1.0)
    return np.clip(ratio, *CORRECTION_RANGE)


def far_radiance_per_irradiance(preset: Preset, kd, moments, light, eye, tilts=None) -> np.ndarray:
    """Radiance per unit sun irradiance of the far field (``filtered_diffuse_light`` with one
    sun and no sky) on a flat surface, +z up, at the mean albedo ``kd`` (3,) and the tile's
    normal ``moments`` (see :func:`moment_normals`), with the five normals' correction by the
    grains' ``tilts`` (:func:`grain_tilts`) where given. ``light`` (3,) and ``eye`` (..., 3)
    are unit directions away from the surface; returns (..., 3)."""
    shading = preset.shading
    kd = np.asarray(kd, dtype=np.float64)
    light = np.asarray(light, dtype=np.float64)
    eye = np.asarray(eye, dtype=np.float64)
    n, weights = moment_normals(moments, eye)
    seen, bent = _facing(n, eye)
    ui = bent @ light
    uo = np.sum(bent * eye[..., None, :], axis=-1)
    cos_io = eye @ light
    fs = np.clip(shading.scattering * shading.sss, 0.0, 1.0)
    fe = np.exp(-shading.absorption * shading.sss)
    lit = float(light[2] > 0.0)
    per_albedo = sphere_brdf(kd, ui[..., None], uo[..., None], cos_io[..., None, None]) / (
        np.maximum(kd, 1e-4)
    )
    direct = (1.0 - fs) * per_albedo * np.maximum(ui, 0.0)[..., None] + fs * fe / np.pi
    diffuse = np.sum((weights * seen)[..., None] * direct, axis=-2) * lit
    if tilts is not None:
        diffuse *= five_normals_correction(tilts, moments, light, eye)[..., None]
    exponent = TRANSMISSION_SHARPEST + (1.0 - TRANSMISSION_SHARPEST) * np.clip(
        shading.transmission_roughness, 0.0, 1.0
    )
    forward = np.maximum(-cos_io, 0.0) ** exponent
    through = shading.transmission * forward[..., None] / np.pi * lit
    # Absorption dims only the light that passes through grains (sand_surface.glsl).
    return kd * (diffuse + fe * through)


def hemisphere(steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Directions about +z and their solid angles: a midpoint rule in cos θ and φ."""
    mu = (np.arange(steps) + 0.5) / steps
    phi = (np.arange(2 * steps) + 0.5) / (2 * steps) * 2.0 * np.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m * m)
    directions = np.stack([s * np.cos(p), s * np.sin(p), m], axis=-1).reshape(-1, 3)
    return directions, np.full(len(directions), (1.0 / steps) * (np.pi / steps))


def lambert_equivalent_albedo(preset: Preset, kd, moments, tilts=None) -> np.ndarray:
    """The albedo of the Lambertian surface that reflects as much of the sun as the far field
    of the tile's normal ``moments`` (see :func:`moment_normals`) and the grains' ``tilts``
    where given (:func:`far_radiance_per_irradiance`): radiance times the eye's
    cosine over the eye's hemisphere, averaged over the light's hemisphere with its cosine as
    weight (suns high and low count as they light the ground). One value per channel of
    ``kd``."""
    kd = np.asarray(kd, dtype=np.float64)
    eyes, d_eye = hemisphere(_EYE_STEPS)
    # The grains' normals are (near enough) isotropic about +z: the light's azimuth need not
    # vary.
    mu = (np.arange(_LIGHT_STEPS) + 0.5) / _LIGHT_STEPS
    lights = np.stack([np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], axis=-1)
    total = np.zeros(3)
    lambert = 0.0
    for light, cos_light in zip(lights, mu, strict=True):
        radiance = far_radiance_per_irradiance(preset, kd, moments, light, eyes, tilts)
        total += cos_light * np.sum(radiance * (eyes[:, 2] * d_eye)[:, None], axis=0)
        # A Lambertian albedo a gives radiance a/π per unit irradiance and cosine of the light.
        lambert += cos_light * np.sum(cos_light / np.pi * eyes[:, 2] * d_eye)
    return total / lambert
