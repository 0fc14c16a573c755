"""Exposure that adapts as an eye does: to the light, and partly to what the scene sends back.

The light sets the base (a surface facing up under the sun, the moon and the sky), with partial
adaptation so that night stays darker than day. The scene then moves it part of the way
towards its own brightness: the log-average luminance of the HDR frame against that of a
mid-grey sand under the same light. Only part of the way, so that black sand still reads as
black and white sand as white, each with its detail; bright sparkles barely move a log-average.
Over time the exposure follows its target as an eye adapts, in about half a second.
"""

from __future__ import annotations

import math
import time

import numpy as np

from sand_editor.colour import LUMINANCE

LIGHT_ADAPTATION = 0.5  # exposure ∝ (light)^−this: partial adaptation keeps night darker
EXPOSURE_KEY = 2.5  # a grey card (albedo 0.18) under the noon sun displays 0.18, as metered
SCENE_ADAPTATION = 0.2  # and ∝ (scene / mid-grey)^−this: a fifth of the way, on a log scale
MID_GREY = 0.18
MAX_SCENE_FACTOR = 4.0  # the scene moves the exposure by at most this, either way
ADAPT_SECONDS = 0.5  # time constant of the eye's adaptation
MIN_EXPOSURE, MAX_EXPOSURE = 1e-2, 1e3


def light_luminance(sky) -> float:
    """Luminance of the light on an upward surface: sun and moon on it, plus the sky."""
    light = (
        sky.sun_radiance * max(float(sky.sun_direction[1]), 0.0)
        + sky.moon_radiance * max(float(sky.moon_direction[1]), 0.0)
        + sky.sky_irradiance
    )
    return float(np.dot(light, LUMINANCE))


def light_exposure(sky) -> float:
    """Exposure for the light alone."""
    luminance = light_luminance(sky)
    exposure = EXPOSURE_KEY / max(luminance, 1e-6) ** LIGHT_ADAPTATION
    return float(np.clip(exposure, MIN_EXPOSURE, MAX_EXPOSURE))


def metered_exposure(sky, scene_luminance: float) -> float:
    """Exposure for the light, moved part of the way towards the scene's log-average
    luminance (``scene_luminance``, HDR) against a mid-grey sand's under that light."""
    base = light_exposure(sky)
    grey = MID_GREY / math.pi * light_luminance(sky)
    if not (math.isfinite(scene_luminance) and scene_luminance > 0.0 and grey > 0.0):
        return base
    factor = (grey / scene_luminance) ** SCENE_ADAPTATION
    factor = min(max(factor, 1.0 / MAX_SCENE_FACTOR), MAX_SCENE_FACTOR)
    return float(np.clip(base * factor, MIN_EXPOSURE, MAX_EXPOSURE))


class EyeAdaptation:
    """The exposure in use, following its target with a time constant (in log exposure)."""

    def __init__(self, seconds: float = ADAPT_SECONDS) -> None:
        self.seconds = seconds
        self.exposure: float | None = None

    def step(self, target: float, dt: float | None) -> float:
        """Move towards ``target`` over ``dt`` seconds; the first step (or dt None) jumps."""
        if self.exposure is None or dt is None or not math.isfinite(dt) or dt < 0:
            self.exposure = float(target)
            return self.exposure
        keep = math.exp(-min(dt, 60.0) / self.seconds)
        log_exposure = keep * math.log(self.exposure) + (1.0 - keep) * math.log(target)
        self.exposure = math.exp(log_exposure)
        return self.exposure

    def reset(self) -> None:
        self.exposure = None


class ExposureControl:
    """The renderer's exposure: fixed when a frame asks for one, else metered from the frame's
    scene, and in views that run on (the editor's, the headset's: ``adapt_over_time``) followed
    over time as an eye adapts, the first frame jumping to it; otherwise each frame takes its
    metered exposure at once, the same on every run."""

    def __init__(self) -> None:
        self.adapt_over_time = False
        self.adaptation = EyeAdaptation()
        self._last_metered: float | None = None

    def for_frame(self, sky, fixed: float | None, light_only: bool):
        """``fixed``, or a function of the frame's log-average scene luminance giving the
        exposure (the light's alone where ``light_only``: a debug view or glints alone, which
        would meter as a black scene)."""
        if fixed is not None:
            return fixed
        now = time.perf_counter()
        last, self._last_metered = self._last_metered, now
        dt = now - last if self.adapt_over_time and last is not None else None

        def exposure(scene_luminance: float) -> float:
            if light_only:
                return light_exposure(sky)
            return self.adaptation.step(metered_exposure(sky, scene_luminance), dt)

        return exposure
