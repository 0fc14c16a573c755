import math

import pytest

from sand_editor.preset import Color, PresetError


@pytest.mark.parametrize(
    ("text", "rgb"),
    [("#ffd7c4", (255, 215, 196)), ("#FFD7C4", (255, 215, 196)), ("#000000", (0, 0, 0))],
)
def test_from_hex_reads_both_cases(text, rgb):
    assert Color.from_hex(text) == Color(*rgb)


@pytest.mark.parametrize(
    "text", ["#fff", "ffd7c4", "#ggd7c4", "#ffd7c4 ", " #ffd7c4", "#ffd7c4ff", "red", "", 123, None]
)
def test_from_hex_refuses_anything_but_rrggbb(text):
    with pytest.raises(ValueError, match="#rrggbb"):
        Color.from_hex(text)


def test_hex_is_lower_case():
    assert Color.from_hex("#AbCdEf").hex == "#abcdef"
    assert str(Color(1, 2, 3)) == "#010203"


@pytest.mark.parametrize("channels", [(256, 0, 0), (0, -1, 0), (0, 0, 1.0), (True, 0, 0)])
def test_channels_must_be_integers_from_0_to_255(channels):
    with pytest.raises(PresetError):
        Color(*channels)


def test_srgb_is_channel_over_255():
    assert Color(0, 51, 255).srgb == (0.0, 0.2, 1.0)


@pytest.mark.parametrize(
    ("channel", "linear"),
    [(0, 0.0), (255, 1.0), (128, 0.2158605), (10, 10 / 255 / 12.92), (11, 0.0033465)],
)
def test_linear_follows_the_srgb_transfer_function(channel, linear):
    assert math.isclose(Color(channel, channel, channel).linear[0], linear, abs_tol=1e-7)
    assert Color(channel, 0, 0).linear[1:] == (0.0, 0.0)


def test_colors_are_hashable_values():
    assert {Color(1, 2, 3): "a"}[Color.from_hex("#010203")] == "a"
