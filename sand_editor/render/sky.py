"""Time of day → sun, moon, sky colours and the light they cast (world: y up, north = −z).

Units are linear RGB in an HDR scale where the noon sun gives an irradiance of about 3 on a
surface facing it; only ratios matter, since exposure follows the light.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

# Sky radiance between horizon (μ = 0) and zenith (μ = 1) is horizon + (zenith − horizon)·μ^p;
# shaders/sky.glsl uses the same exponent, so the irradiance below matches what is drawn.
SKY_GRADIENT_EXPONENT = 0.5

SUN_IRRADIANCE_TOP = np.array([3.4, 3.3, 3.2])  # outside the atmosphere, so ≈ 3 at noon
MOON_IRRADIANCE_TOP = np.array([0.010, 0.012, 0.016])  # bluish, as night vision perceives it
# Optical depth per air mass: blue scatters out first, so the low sun turns red.
OPTICAL_DEPTH = np.array([0.06, 0.11, 0.24])

SKY_DAY = (np.array([0.05, 0.11, 0.25]), np.array([0.18, 0.22, 0.28]))  # (zenith, horizon)
SKY_SUNSET = (np.array([0.035, 0.05, 0.10]), np.array([0.36, 0.17, 0.06]))
SKY_NIGHT = (np.array([0.0006, 0.0010, 0.0030]), np.array([0.0015, 0.0020, 0.0040]))

# ASCII only: "\d" would take other scripts' digits ("١٢:٠٠"), and "\s" without re.ASCII any
# Unicode space.
_TIME = re.compile(r"\s*([0-9]{1,2}):([0-9]{2})\s*", re.ASCII)


def parse_time(text: str) -> float:
    """Hours since midnight from ``"HH:MM"`` (00:00–23:59, or 24:00)."""
    match = _TIME.fullmatch(text) if isinstance(text, str) else None
    if match:
        hours, minutes = int(match.group(1)), int(match.group(2))
        if (hours < 24 and minutes < 60) or (hours, minutes) == (24, 0):
            return hours + minutes / 60.0
    raise ValueError(f"time of day must be 'HH:MM' from 00:00 to 23:59 (or 24:00), got {text!r}")


@dataclass(frozen=True)
class SkyState:
    """Everything the renderer needs of the sky at one moment; vectors are float32 (3,)."""

    time_hours: float
    sun_direction: np.ndarray  # unit, towards the sun
    moon_direction: np.ndarray  # unit, towards the moon
    sun_radiance: np.ndarray  # irradiance at normal incidence; 0 below the horizon
    moon_radiance: np.ndarray
    sky_zenith: np.ndarray  # radiance straight up
    sky_horizon: np.ndarray  # radiance at the horizon
    sky_irradiance: np.ndarray  # cosine-weighted sky light on an upward surface
    star_visibility: float  # 0 by day, 1 at night

    @property
    def sun_elevation_deg(self) -> float:
        return math.degrees(math.asin(float(np.clip(self.sun_direction[1], -1, 1))))


def sky_at(time_hours: float, latitude_deg: float = 25.0, day_of_year: int = 172) -> SkyState:
    """The sky at local solar time ``time_hours`` (12 = noon) at ``latitude_deg``."""
    if not math.isfinite(time_hours):
        raise ValueError(f"time_hours must be finite, got {time_hours}")
    declination = -23.44 * math.cos(2 * math.pi / 365.0 * (day_of_year + 10))
    sun = celestial_direction(time_hours, declination, latitude_deg)
    # A full-ish moon: opposite declination, transiting two hours after midnight.
    moon = celestial_direction(time_hours + 10.0, -declination, latitude_deg)
    sun_elevation = math.degrees(math.asin(float(sun[1])))
    moon_elevation = math.degrees(math.asin(float(moon[1])))

    day = _smoothstep(0.0, 20.0, sun_elevation)
    twilight = _smoothstep(-12.0, 0.0, sun_elevation)
    zenith, horizon = (
        _mix(_mix(night, sunset, twilight), noon, day)
        for night, sunset, noon in zip(SKY_NIGHT, SKY_SUNSET, SKY_DAY, strict=True)
    )
    # ∫ L cosθ dω over the upper hemisphere for the gradient profile above.
    weight = 2.0 / (SKY_GRADIENT_EXPONENT + 2.0)
    irradiance = math.pi * (horizon + (zenith - horizon) * weight)

    def f32(v) -> np.ndarray:
        return np.asarray(v, dtype=np.float32)

    return SkyState(
        time_hours=float(time_hours % 24.0),
        sun_direction=f32(sun),
        moon_direction=f32(moon),
        sun_radiance=f32(SUN_IRRADIANCE_TOP * _transmittance(sun_elevation)),
        moon_radiance=f32(MOON_IRRADIANCE_TOP * _transmittance(moon_elevation)),
        sky_zenith=f32(zenith),
        sky_horizon=f32(horizon),
        sky_irradiance=f32(irradiance),
        star_visibility=1.0 - _smoothstep(-10.0, -4.0, sun_elevation),
    )


def celestial_direction(time_hours: float, declination_deg: float, latitude_deg: float):
    """Unit world vector to a body of the given declination at local solar time (x east,
    y up, z south)."""
    hour_angle = math.radians(15.0 * (time_hours - 12.0))
    dec, lat = math.radians(declination_deg), math.radians(latitude_deg)
    east = -math.cos(dec) * math.sin(hour_angle)
    north = math.sin(dec) * math.cos(lat) - math.cos(dec) * math.cos(hour_angle) * math.sin(lat)
    up = math.sin(dec) * math.sin(lat) + math.cos(dec) * math.cos(hour_angle) * math.cos(lat)
    direction = np.array([east, up, -north])
    return direction / np.linalg.norm(direction)


def _transmittance(elevation_deg: float) -> np.ndarray:
    """Fraction of light through the atmosphere; fades smoothly to 0 from +2° to −1°."""
    clamped = max(elevation_deg, 0.0)
    # Kasten & Young's air mass stays finite at the horizon (≈ 38).
    air_mass = 1.0 / (math.sin(math.radians(clamped)) + 0.50572 * (clamped + 6.07995) ** -1.6364)
    return np.exp(-OPTICAL_DEPTH * air_mass) * _smoothstep(-1.0, 2.0, elevation_deg)


def _smoothstep(edge0: float, edge1: float, x: float) -> float:
    t = min(max((x - edge0) / (edge1 - edge0), 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


def _mix(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    return a + (b - a) * t
