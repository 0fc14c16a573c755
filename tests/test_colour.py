"""The shared colour facts: luminance weights and the sRGB transfer curve."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.colour import LUMINANCE, linear_to_srgb, luminance, srgb_to_linear
from sand_editor.preset import Color


def test_white_has_unit_luminance_and_the_weights_are_rec709():
    assert sum(LUMINANCE) == pytest.approx(1.0)
    assert luminance([1.0, 1.0, 1.0]) == pytest.approx(1.0)
    assert luminance([0.0, 1.0, 0.0]) == pytest.approx(0.7152)


def test_the_srgb_curve_is_the_piecewise_standard_and_inverts():
    assert srgb_to_linear(0.5) == pytest.approx(0.21404, abs=1e-5)  # not 0.5**2.2 = 0.2176
    assert srgb_to_linear(0.04) == pytest.approx(0.04 / 12.92)
    values = np.linspace(0.0, 1.0, 1001)
    assert linear_to_srgb(srgb_to_linear(values)) == pytest.approx(values, abs=1e-12)
    # Continuous at the knee, monotonic throughout.
    assert np.all(np.diff(srgb_to_linear(values)) > 0)


def test_preset_colours_decode_with_the_same_curve():
    colour = Color.from_hex("#80c0ff")
    expected = srgb_to_linear(np.array([0x80, 0xC0, 0xFF]) / 255.0)
    assert colour.linear == pytest.approx(tuple(expected))
