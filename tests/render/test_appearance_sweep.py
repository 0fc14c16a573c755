"""Every shipped sand and random valid ones drawn from the whole field table, at 0.3, 1 and 10 m
under a high and a low sun: no NaN or inf; where the light is mostly diffuse, no black close frame
and at most 1 % of the ground clipped white; the close and far frames' displayed means within
10 % where glints carry few enough (6 %) that the display curve could not move them further; and
the close range's light the far range's — in expectation within 10 %, and as drawn (sparkles and
all) within 10 % plus the Poisson spread of the facets drawn.

The random draw changes every run; the seed is printed, ``SAND_EDITOR_SWEEP_SEED`` repeats it,
and a failure names the file it wrote the failing preset to (``sand-editor render FILE`` shows
it)."""

from __future__ import annotations

import json
import os
import secrets

import numpy as np
import pytest

from sand_editor.bench.sweep import (
    DRAW_SIGMAS,
    MIN_GRAINS_ACROSS,
    SHIPPED,
    Sweep,
    draw_bound,
    random_preset,
    sweep_presets,
)
from sand_editor.preset import FIELDS, FORMAT, SCHEMA_VERSION, Preset
from sand_editor.resources import bundled_preset

RANDOM_PRESETS = int(os.environ.get("SAND_EDITOR_SWEEP_PRESETS", "6"))
SEED = int(os.environ.get("SAND_EDITOR_SWEEP_SEED", str(secrets.randbelow(2**31))))
DISTANCES = (0.3, 1.0, 10.0)
AGREEMENT = 0.10
# A close frame darker than this share of the far one reads as black beside it.
BLACK_SHARE = 0.5
# A view whose light is mostly glints shows it as sparse sparkles, each brighter than the display
# can show: its displayed mean falls short of the far frame's and its sparkles clip, as a
# photograph of glittering sand does. Such views are held to the HDR agreement only.
GLINT_DOMINATED = 0.5
# The display curve (ACES, sRGB) spreads a relative change of the scene's light over at most
# this many times as much of the displayed light, at any level a sand is shown at (measured by
# the post chain itself below): 1.6 in the shadows and mid-tones, falling in the highlights.
DISPLAY_ELASTICITY = 1.65
# Where glints carry at most this share of the light, the displayed frames agree as HDR does:
# even were all of it clipped away by the display, the displayed mean would move by at most
# AGREEMENT.
GLINTS_CARRY_LITTLE = AGREEMENT / DISPLAY_ELASTICITY


def _diffuse_led(row: dict) -> bool:
    return row["glint_share"] <= GLINT_DOMINATED


@pytest.fixture(scope="module")
def sweep(gl_ctx):
    s = Sweep(gl_ctx)
    yield s
    s.release()


@pytest.fixture(scope="module")
def presets():
    print(f"appearance sweep seed {SEED} (SAND_EDITOR_SWEEP_SEED={SEED} repeats it)")
    return {preset.name: preset for preset in sweep_presets(RANDOM_PRESETS, SEED)}


@pytest.fixture(scope="module")
def rows(sweep, presets):
    return [row for preset in presets.values() for row in sweep.measure(preset, DISTANCES)]


@pytest.fixture(scope="module")
def explain(presets, tmp_path_factory):
    """A failure's message: the view, and the preset written to a file."""
    folder = tmp_path_factory.mktemp("sweep-failures")

    def message(row: dict) -> str:
        path = folder / f"{row['preset']}.json"
        presets[row["preset"]].save(path)
        view = {k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}
        return f"seed {SEED}: {json.dumps(view)}; preset written to {path}"

    return message


def test_no_nan_or_inf_anywhere(rows, explain):
    for row in rows:
        assert row["finite"], explain(row)


def test_at_most_one_percent_of_the_ground_is_clipped_white(rows, explain):
    # A view of a few grains is a view of stones: their mirror image of the sun may clip.
    held = [row for row in rows if _diffuse_led(row) and row["compared"]]
    # Under a high sun every shipped sand is mostly diffuse, so each is held here (black sand
    # under a low sun sends back more glint than diffuse light, as dark sand does).
    assert all(
        _diffuse_led(row) for row in rows if row["preset"] in SHIPPED and row["sun"] == "noon"
    )
    worst = max(held, key=lambda row: row["clipped"])
    assert worst["clipped"] <= 0.01, explain(worst)


def test_close_and_far_hold_the_same_light_in_expectation(rows, explain):
    compared = [row for row in rows if row["compared"]]
    assert len(compared) >= len(rows) // 4, "the sweep compared too few views to mean anything"
    for row in compared:
        assert abs(row["close_over_far"] - 1.0) <= AGREEMENT, explain(row)


def test_the_drawn_sparkles_keep_the_far_light_within_their_spread(rows, explain):
    for row in (row for row in rows if row["compared"]):
        allowed = AGREEMENT * row["far"] + draw_bound(row["draw_sigma"], row["draw_largest"])
        assert abs(row["close"] - row["far"]) <= allowed, explain(row)


def test_the_draw_bound_is_the_normal_one_for_many_facets_and_wider_for_few():
    assert draw_bound(0.01, 0.0) == pytest.approx(DRAW_SIGMAS * 0.01)
    assert draw_bound(0.01, 1e-6) == pytest.approx(DRAW_SIGMAS * 0.01, rel=1e-3)
    # A few facets, each a large part of the frame's light: one may be drawn on its own.
    assert draw_bound(0.03, 0.095) > 0.095
    # Against drawn frames: 3 facets expected, each 1/3 of the frame's glint; the bound holds for
    # all but the rare frame a normal bound of 3σ would allow, and a normal 3σ fails many more.
    rng = np.random.default_rng(7)
    unit, expected = 1.0 / 3.0, 3.0
    draws = rng.poisson(expected, 200_000) * unit
    sigma = np.sqrt(expected) * unit
    beyond = np.abs(draws - 1.0) > draw_bound(sigma, unit)
    assert beyond.mean() < 0.005
    assert (np.abs(draws - 1.0) > DRAW_SIGMAS * sigma).mean() > 2 * beyond.mean()


def test_no_close_frame_is_black_beside_its_far_frame(rows, explain):
    # Even were every sparkle clipped away, the close frame keeps its diffuse light, which the
    # display shows as at least that share to the display curve's elasticity (a sand of 45 %
    # glint light, a few sparkles of it clipped at 0.3 m, displayed 45 % of its far frame).
    held = [row for row in rows if row["compared"] and _diffuse_led(row)]
    for row in held:
        kept = (1.0 - row["glint_share"]) ** DISPLAY_ELASTICITY
        assert row["frame_close"] >= BLACK_SHARE * kept * row["frame_far"], explain(row)


def test_close_and_far_frames_look_the_same_where_glints_carry_little(rows, explain):
    # What a person sees: the final frames' mean decoded luminance at the light's exposure. Where
    # sparkles carry much of the light, the display clips them (the close frame darker) or its
    # toe brightens their spread (lighter): such views are held to the HDR agreement above.
    held = [row for row in rows if row["compared"] and row["glint_share"] <= GLINTS_CARRY_LITTLE]
    assert held
    for row in held:
        assert row["frame_close"] == pytest.approx(row["frame_far"], rel=AGREEMENT), explain(row)


def test_the_display_curve_moves_the_displayed_light_at_most_by_its_elasticity(gl_ctx):
    # A uniform scene at levels from a dark sand's to a white one's, and 25 % more of it,
    # through the real resolve (exposure 1, no bloom): the displayed luminance's log ratio over
    # the scene's.
    from sand_editor.colour import luminance, srgb_to_linear
    from sand_editor.render.post import PostChain

    chain = PostChain(gl_ctx)
    target_texture = gl_ctx.texture((8, 8), 4)
    target = gl_ctx.framebuffer([target_texture])
    try:
        chain.resize(8, 8)

        def displayed(level: float) -> float:
            chain.scene_framebuffer.clear(level, level, level, 1.0)
            chain.finish(target, (0, 0, 8, 8), 1.0, bloom_strength=0.0)
            pixels = np.frombuffer(target.read(components=3), dtype=np.uint8).reshape(-1, 3)
            return float(luminance(srgb_to_linear(pixels / 255.0)).mean())

        step = 1.25
        elasticities = []
        for level in np.geomspace(0.04, 4.0, 12):
            low, high = displayed(level), displayed(level * step)
            assert 0.0 < low < high <= 1.0
            elasticities.append(np.log(high / low) / np.log(step))
    finally:
        target.release()
        target_texture.release()
        chain.release()
    assert max(elasticities) <= DISPLAY_ELASTICITY, elasticities
    assert max(elasticities) >= 0.9 * DISPLAY_ELASTICITY  # the bound is the curve's, not loose


def test_the_shipped_sands_are_compared_at_every_distance(rows):
    shipped = [row for row in rows if row["preset"] in SHIPPED]
    assert shipped and all(row["compared"] for row in shipped)
    assert all(row["grains_across"] >= MIN_GRAINS_ACROSS for row in shipped)


def test_shipped_glints_draw_close_to_their_expectation(rows, explain):
    # The shipped sands hold enough facets in every view that the draw's spread is small.
    for row in (row for row in rows if row["preset"] in SHIPPED and row["distance_m"] >= 1.0):
        assert row["draw_sigma"] <= 0.1 * row["far"], explain(row)


def test_random_presets_reach_every_fields_extremes():
    rng = np.random.default_rng(SEED)
    presets = [random_preset(rng) for _ in range(400)]
    for spec in FIELDS:
        if spec.kind not in ("float", "int") or spec.section == "":
            continue
        values = [p.get(spec.path) for p in presets]
        assert spec.minimum in values and spec.maximum in values, spec.path
        inside = [v for v in values if spec.minimum < v < spec.maximum]
        assert inside, spec.path
        if spec.minimum > 0 and spec.maximum / spec.minimum >= 100:
            # Log-uniform over decades: the lower decades are drawn as often as the upper.
            middle = np.sqrt(spec.minimum * spec.maximum)
            below = sum(v < middle for v in inside)
            assert 0.3 <= below / len(inside) <= 0.7, spec.path


def test_subsurface_absorption_leaves_the_colour_the_grains_were_given(sweep):
    # Strong absorption along long paths dims only the light that passes through grains: the
    # sand's colour stays the one its grains were given (it made every colour black before).
    base = Preset.load(bundled_preset("paper-default"))
    means = []
    for absorption, sss in ((0.0, 0.0), (10.0, 10.0)):
        preset = base.replace(**{"shading.absorption": absorption, "shading.sss": sss,
                                 "shading.scattering": 0.0})  # fmt: skip
        sweep.material.update(preset)
        sweep.renderer.set_material(sweep.material)
        frame, _ = sweep.frame(1.0, "12:00", "far")
        means.append(frame[frame.shape[0] // 2 :].astype(float).mean())
    assert means[1] == pytest.approx(means[0], rel=0.02)
    assert means[1] > 50


def test_tiny_grains_with_large_facets_are_not_black_up_close(sweep):
    # A valid preset a slider drag reaches: dark grains 0.3 µm apart, facets 1 mm, every grain
    # clear, so that half its light is glints.
    # Facets a thousand times wider than their grains drew the glints' light into a few rare
    # sparkles: the close frame was a quarter of the far one. A facet is never wider than its
    # grain, so this sand shows the far frame's sheen up close too.
    preset = Preset.load(bundled_preset("paper-default")).replace(**{
        "shading.uv_scale": 10_000.0, "generation.period": 256, "shading.facet_size": 1000.0,
        "shading.facet_roughness": 1.0, "shading.clear_grains": 1.0, "shading.grain_ior": 2.06,
        "shading.ripple_strength": 0.0, "generation.base_color": "#302420",
        "generation.colors": ("#3c2d1d", "#272019", "#413a37", "#2a2420"),
    })  # fmt: skip
    (row,) = sweep.measure(preset, distances=(0.3,), suns=("noon",))
    assert row["compared"] and row["glint_share"] > 0.2, "the view is not glint-lit"
    assert row["frame_close"] == pytest.approx(row["frame_far"], rel=AGREEMENT)
    assert abs(row["drawn_over_far"] - 1.0) <= AGREEMENT


def test_black_sand_is_black_and_glints(sweep):
    sweep.material.update(Preset.load(bundled_preset("black-volcanic")))
    sweep.renderer.set_material(sweep.material)
    size, sweep.frame_size = sweep.frame_size, (320, 180)  # the size the views use
    try:
        frame, _ = sweep.frame(0.3, "16:30")
    finally:
        sweep.frame_size = size
    ground = frame[frame.shape[0] // 2 :].astype(float) / 255.0
    linear = np.where(ground <= 0.04045, ground / 12.92, ((ground + 0.055) / 1.055) ** 2.4)
    luminance = linear @ np.array([0.2126, 0.7152, 0.0722])
    assert np.median(luminance) < 0.08, "black sand reads dark"
    # ... and its clear volcanic glass shows sparkles far brighter than the sand around them.
    assert (luminance > 10 * np.median(luminance)).mean() > 0.001


def _sand(name: str, generation: dict, shading: dict) -> Preset:
    """A sand as its preset file holds it (read as a file is, so every field is checked)."""
    return Preset.from_dict({"format": FORMAT, "schema_version": SCHEMA_VERSION, "name": name,
                             "generation": generation, "shading": shading})  # fmt: skip


# A random valid sand whose tile is one lopsided grain (period 1): the copies the tile is laid
# in turn it eight ways, and the far range must shade that mixture, not the tile as it lies.
ONE_GRAIN = _sand(
    "one-lopsided-grain",
    generation={
        "layers": 2, "threshold": 0.0, "roundness": 0.0, "seed": 4294967295,
        "base_color": "#59d823", "colors": ["#48b306", "#89b23c", "#2f77b3", "#a48e63"],
        "weights": [63, 96, 96, 0], "layer_darkness": 0.734, "jitter": 0.683, "period": 1,
    },
    shading={
        "facet_roughness": 0.01, "facet_size": 1000.0, "clear_grains": 0.484,
        "grain_ior": 1.97, "sss": 10.0, "scattering": 0.53, "absorption": 5.2,
        "transmission": 1.0, "transmission_roughness": 0.0, "ripple_strength": 1.0,
        "wind_direction": 0.0, "detail_strength": 0.0, "sigmoid_a": 100.0, "sigmoid_b": -100.0,
        "uv_scale": 10000.0,
    },
)  # fmt: skip


def test_a_one_grain_tile_laid_in_turned_copies_is_the_same_light_far_away(sweep):
    rows = sweep.measure(ONE_GRAIN, (0.3, 10.0), ("low",))
    for row in rows:
        # As the tile lies (unsymmetrized) its far light was 0.856 and 0.895 of the close's.
        assert abs(row["close_over_far"] - 1.0) <= 0.05, row


# A random valid sand of the strongest ripples (slopes to 8) and no glint: under a low sun a far
# pixel holds a few ripples' sides turned to the light and from it, whose spread the display
# curve takes as the close range's.
STRONG_RIPPLES = _sand(
    "strong-ripples",
    generation={
        "layers": 0, "threshold": 0.0, "roundness": 1.0, "seed": 4294967295,
        "base_color": "#6a7940", "colors": ["#141ca1", "#55d489", "#971a83", "#ec12bb"],
        "weights": [95, 23, 95, 31], "layer_darkness": 0.0, "jitter": 0.0, "period": 144,
    },
    shading={
        "facet_roughness": 0.427, "facet_size": 20.0, "clear_grains": 1.0, "grain_ior": 1.3,
        "sss": 10.0, "scattering": 0.0, "absorption": 0.0, "transmission": 0.0,
        "transmission_roughness": 0.904, "ripple_strength": 1.0, "wind_direction": 360.0,
        "detail_strength": 0.0, "sigmoid_a": 0.0816, "sigmoid_b": -100.0, "uv_scale": 0.315,
    },
)  # fmt: skip


def test_strong_ripples_display_alike_close_and_far(sweep):
    (row,) = sweep.measure(STRONG_RIPPLES, (10.0,), ("low",))
    assert row["glint_share"] <= GLINTS_CARRY_LITTLE, row
    # 0.5 % apart. With the far range's light taken as even across its pixels, the close frame
    # displayed 12 % lighter than the far one; at two tilts either side of the mean slope, with
    # the sky at the mean slope, 4 % (and both 42 % lighter in HDR than now).
    assert row["frame_close"] == pytest.approx(row["frame_far"], rel=0.02), row


# A random valid sand (the sweep's seed 401104719) of faceted grains on a regular grid (no
# jitter, period 256) with mirror-like facets: on the sweep's 256² tile a cell spans one texel,
# whose grains' normals read as one slope everywhere unless the tile is built from finer points
# (material.py's supersampling).
REGULAR_FACETS = _sand(
    "regular-facets",
    generation={
        "layers": 7, "threshold": 0.0, "roundness": 0.0089, "seed": 725268993,
        "base_color": "#b03f45", "colors": ["#c4574b", "#ba9f73", "#26515b", "#eacc51"],
        "weights": [36, 21, 36, 4], "layer_darkness": 0.391, "jitter": 0.0, "period": 256,
    },
    shading={
        "facet_roughness": 0.01, "facet_size": 20.0, "clear_grains": 0.977, "grain_ior": 1.806,
        "sss": 0.0, "scattering": 0.0, "absorption": 1.25, "transmission": 0.0,
        "transmission_roughness": 0.0, "ripple_strength": 0.218, "wind_direction": 73.1,
        "detail_strength": 1.0, "sigmoid_a": 37.3, "sigmoid_b": 1000.0, "uv_scale": 0.553,
    },
)  # fmt: skip


def test_grains_finer_than_the_tile_hold_close_and_far_light_alike(sweep):
    rows = sweep.measure(REGULAR_FACETS, (1.0, 10.0))
    for row in rows:
        # Built from one point a texel, at 1 m under the low sun the close range's light was
        # 0.54 of the far range's and drawn 3.3 times it; at noon 1.10 and 1.18.
        assert abs(row["close_over_far"] - 1.0) <= AGREEMENT, row
        assert abs(row["drawn_over_far"] - 1.0) <= AGREEMENT, row


# A random valid sand (seed 1014's sixth) of grains far below the pixel from 10 m on: a one-cell
# tile at 354 per metre, no clear grains, all of its light wrapped around the grains.
FINE_WRAPPED = _sand(
    "fine-wrapped",
    generation={
        "layers": 5, "threshold": 0.0, "roundness": 1.0, "seed": 0,
        "base_color": "#affff3", "colors": ["#f59ff0", "#16d398", "#181ac6", "#ce78da"],
        "weights": [52, 38, 12, 52], "layer_darkness": 0.859, "jitter": 0.606, "period": 1,
    },
    shading={
        "facet_roughness": 1.0, "facet_size": 1000.0, "clear_grains": 0.0, "grain_ior": 1.3,
        "sss": 10.0, "scattering": 1.0, "absorption": 0.0, "transmission": 1.0,
        "transmission_roughness": 0.0, "ripple_strength": 0.47, "wind_direction": 360.0,
        "detail_strength": 0.0, "sigmoid_a": 100.0, "sigmoid_b": -100.0, "uv_scale": 353.6,
    },
)  # fmt: skip


def test_grains_far_below_the_pixel_display_as_the_far_range_does(sweep):
    rows = sweep.measure(FINE_WRAPPED, (10.0, 30.0), ("low",))
    for row in rows:
        assert row["glint_share"] == 0.0 and row["close_over_far"] == pytest.approx(1.0, abs=0.01)
        # With their shadows' and normals' spread taken whole at any size, the close frame
        # displayed 0.90 of the far one (the curve's shoulder).
        assert row["frame_close"] == pytest.approx(row["frame_far"], rel=0.03), row
