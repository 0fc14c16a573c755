from __future__ import annotations

import numpy as np
import pytest

from sand_editor.render.sky import parse_time, sky_at


def elevation(time_hours: float) -> float:
    return sky_at(time_hours).sun_elevation_deg


def test_the_sun_climbs_through_the_morning_and_sets_at_night():
    assert elevation(12.0) > elevation(9.0) > elevation(7.0) > 0.0
    assert elevation(0.0) < 0.0
    # Morning sun in the east (+x), evening sun in the west.
    assert sky_at(8.0).sun_direction[0] > 0.5
    assert sky_at(16.0).sun_direction[0] < -0.5


@pytest.mark.parametrize("time_hours", np.linspace(0.0, 24.0, 13))
def test_directions_are_unit_and_light_is_never_negative(time_hours):
    sky = sky_at(time_hours)
    for direction in (sky.sun_direction, sky.moon_direction):
        assert np.linalg.norm(direction) == pytest.approx(1.0, abs=1e-6)
    for colour in (sky.sun_radiance, sky.moon_radiance, sky.sky_irradiance, sky.sky_zenith):
        assert np.isfinite(colour).all() and (colour >= 0).all()


def test_no_sun_at_night_and_a_redder_sun_at_sunset():
    assert np.all(sky_at(0.0).sun_radiance == 0.0)
    noon, sunset = sky_at(12.0).sun_radiance, sky_at(18.4).sun_radiance
    assert sunset.sum() > 0.0
    assert sunset[0] / sunset[2] > 1.5 * noon[0] / noon[2]


def test_the_moon_is_up_at_midnight_opposite_the_sun():
    sky = sky_at(0.0)
    assert sky.moon_direction[1] > 0.2
    assert np.dot(sky.moon_direction, sky.sun_direction) < 0.0
    assert sky.moon_radiance.sum() > 0.0


def test_stars_at_midnight_only():
    assert sky_at(0.0).star_visibility == pytest.approx(1.0)
    assert sky_at(12.0).star_visibility == 0.0


def test_sky_irradiance_follows_the_sky_colours():
    day, night = sky_at(12.0), sky_at(0.0)
    assert day.sky_irradiance.sum() > 50 * night.sky_irradiance.sum()
    assert day.sky_irradiance[2] > day.sky_irradiance[0], "a clear day sky lights in blue"
    # Between π·horizon and π·zenith: cosine-weighted radiance of the drawn gradient.
    low = np.pi * np.minimum(day.sky_zenith, day.sky_horizon)
    high = np.pi * np.maximum(day.sky_zenith, day.sky_horizon)
    assert np.all((low <= day.sky_irradiance + 1e-6) & (day.sky_irradiance <= high + 1e-6))


@pytest.mark.parametrize(
    "text, hours", [("00:00", 0.0), ("07:30", 7.5), ("9:05", 9 + 5 / 60), ("23:59", 23 + 59 / 60)]
)
def test_parse_time(text, hours):
    assert parse_time(text) == pytest.approx(hours)


def test_parse_time_accepts_24_00():
    assert parse_time("24:00") == 24.0


@pytest.mark.parametrize(
    "text",
    ["24:01", "25:00", "12:60", "12", "noon", "12:5", "-1:00", "",
     "١٢:٠٠", "12:٠٠", "１２:００", "\u200312:00"],  # other scripts' digits, a Unicode space
)  # fmt: skip
def test_parse_time_names_the_allowed_form(text):
    with pytest.raises(ValueError, match="HH:MM"):
        parse_time(text)
