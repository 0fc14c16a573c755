"""Colour facts every part shares, written once: the luminance weights of linear sRGB (Rec. 709
primaries) and the sRGB transfer curve (IEC 61966-2-1, not the 2.2 power approximation). Every
shader program gets both as #defines (``SHADER_DEFINES``, which sand_editor/gl.py adds to each).
Standard library at import (the preset model decodes its colours here); numpy only where arrays
are asked for."""

from __future__ import annotations

LUMINANCE = (0.2126, 0.7152, 0.0722)
# The curve: linear with slope 1/12.92 below the knee, a 2.4 power of (c + 0.055)/1.055 above.
_KNEE = 0.04045
_LINEAR_KNEE = 0.0031308
_SLOPE = 12.92
_OFFSET = 0.055
_POWER = 2.4
SHADER_DEFINES = {
    "LUMINANCE_WEIGHTS": "vec3({!r}, {!r}, {!r})".format(*LUMINANCE),
    "SRGB_LINEAR_KNEE": repr(_LINEAR_KNEE),
    "SRGB_SLOPE": repr(_SLOPE),
    "SRGB_OFFSET": repr(_OFFSET),
    "SRGB_POWER": repr(_POWER),
}


def srgb_decode(encoded: float) -> float:
    """One sRGB-encoded value in [0, 1] to linear light."""
    if encoded <= _KNEE:
        return encoded / _SLOPE
    return ((encoded + _OFFSET) / (1.0 + _OFFSET)) ** _POWER


def luminance(rgb):
    """Luminance of linear RGB values (…, 3), as a numpy array."""
    import numpy as np

    return np.asarray(rgb, dtype=np.float64) @ np.asarray(LUMINANCE)


def srgb_to_linear(c):
    """Decode sRGB-encoded values in [0, 1] (any array shape) to linear light."""
    import numpy as np

    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= _KNEE, c / _SLOPE, ((c + _OFFSET) / (1.0 + _OFFSET)) ** _POWER)


def linear_to_srgb(c):
    """Encode linear light (clipped to [0, 1], any array shape) with the sRGB curve."""
    import numpy as np

    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    encoded = (1.0 + _OFFSET) * c ** (1.0 / _POWER) - _OFFSET
    return np.where(c <= _LINEAR_KNEE, c * _SLOPE, encoded)
