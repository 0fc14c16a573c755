import dataclasses
import math

import pytest

from sand_editor.preset import Color, Generation, Preset, PresetError, Shading


@pytest.mark.parametrize(
    ("make", "expected"),
    [
        (lambda: Generation(threshold=2), ["generation.threshold", "2", "allowed 0 to 1"]),
        (lambda: Generation(threshold=-0.1), ["generation.threshold", "allowed 0 to 1"]),
        (lambda: Generation(threshold=math.nan), ["generation.threshold", "finite numbers only"]),
        (lambda: Generation(jitter=math.inf), ["generation.jitter", "finite numbers only"]),
        (lambda: Generation(threshold="0.3"), ["generation.threshold", "a string"]),
        (lambda: Generation(threshold=True), ["generation.threshold", "a boolean"]),
        (lambda: Generation(layers=3.5), ["generation.layers", "an integer"]),
        (lambda: Generation(layers=3.0), ["generation.layers", "an integer"]),
        (lambda: Generation(layers=True), ["generation.layers", "an integer"]),
        (lambda: Generation(layers=16), ["generation.layers", "allowed 0 to 15"]),
        (lambda: Generation(seed=2**32), ["generation.seed", "allowed 0 to 4294967295"]),
        (lambda: Generation(period=0), ["generation.period", "allowed 1 to 256"]),
        (lambda: Generation(weights=(0, 0, 0, 0)), ["generation.weights", "at least one above 0"]),
        (lambda: Generation(weights=(1, 2, 101, 3)), ["generation.weights[2]", "0 to 100"]),
        (lambda: Generation(weights=(1, 2, 3)), ["generation.weights", "exactly 4"]),
        (lambda: Generation(weights=5), ["generation.weights", "an array"]),
        (lambda: Generation(colors=("#000000",) * 5), ["generation.colors", "exactly 4"]),
        (
            lambda: Generation(colors=("#000000", "#00000", "#000000", "#000000")),
            ["generation.colors[1]", "#rrggbb"],
        ),
        (lambda: Generation(base_color=(1, 2, 3)), ["generation.base_color", "#rrggbb"]),
        (lambda: Shading(clear_grains=1.5), ["shading.clear_grains", "allowed 0 to 1"]),
        (lambda: Shading(facet_roughness=0), ["shading.facet_roughness", "allowed 0.01 to 1"]),
        (lambda: Shading(grain_ior=1.0), ["shading.grain_ior", "allowed 1.3 to 2.5"]),
        (lambda: Shading(sigmoid_b=-101), ["shading.sigmoid_b", "allowed -100 to 1000"]),
        (lambda: Preset(name=""), ["name", "allowed 1 to 80"]),
        (lambda: Preset(name="x" * 81), ["name", "allowed 1 to 80"]),
        (lambda: Preset(name="two\nlines"), ["name", "printable"]),
        (lambda: Preset(description="x" * 2001), ["description", "allowed 0 to 2000"]),
        (lambda: Preset(description="bell\a"), ["description", "printable"]),
        (lambda: Preset(generation=Shading()), ["generation", "allowed a Generation"]),
    ],
)
def test_invalid_values_name_the_field_and_what_is_allowed(make, expected):
    with pytest.raises(PresetError) as caught:
        make()
    for part in expected:
        assert part in str(caught.value)


def test_values_are_stored_in_canonical_form():
    generation = Generation(threshold=0, colors=["#FFFFFF"] * 4, weights=[1, 2, 3, 4])
    assert type(generation.threshold) is float
    assert generation.colors == (Color(255, 255, 255),) * 4
    assert generation.weights == (1.0, 2.0, 3.0, 4.0)
    assert all(type(weight) is float for weight in generation.weights)


def test_description_may_span_lines():
    assert Preset(description="one\ntwo\tthree").description == "one\ntwo\tthree"


def test_presets_are_frozen_and_hashable():
    preset = Preset()
    with pytest.raises(dataclasses.FrozenInstanceError):
        preset.generation.threshold = 0.5  # type: ignore[misc]
    cache = {Generation(): "textures"}
    assert cache[Generation(colors=list(Generation().colors))] == "textures"
    assert hash(Preset()) == hash(preset)
    assert Generation(seed=1) != Generation(seed=2)


def test_replace_with_dotted_paths():
    preset = Preset()
    changes = {"generation.threshold": 0.4, "shading.clear_grains": 0, "name": "x"}
    changed = preset.replace(**changes)
    assert changed.generation.threshold == 0.4
    assert changed.shading.clear_grains == 0.0
    assert changed.name == "x"
    assert changed.generation.layers == preset.generation.layers
    assert preset.generation.threshold == 0.296  # the original is untouched


def test_replace_with_a_section_object_then_dotted_paths_into_it():
    changed = Preset().replace(generation=Generation(layers=3), **{"generation.seed": 9})
    assert (changed.generation.layers, changed.generation.seed) == (3, 9)


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"generation.threshold": 1.5}, ["generation.threshold", "allowed 0 to 1"]),
        ({"shading.clear_grains": -0.1}, ["shading.clear_grains", "allowed 0 to 1"]),
        ({"generation.treshold": 0.4}, ["generation.treshold", "'generation.threshold'"]),
        ({"threshold": 0.4}, ["threshold", "unknown field"]),
        ({"generation.layers.x": 1}, ["generation.layers.x", "unknown field"]),
        ({"shading": Generation()}, ["shading", "allowed a Shading"]),
    ],
)
def test_replace_refuses_invalid_changes(changes, expected):
    with pytest.raises(PresetError) as caught:
        Preset().replace(**changes)
    for part in expected:
        assert part in str(caught.value)


def test_get_reads_dotted_paths_and_sections():
    preset = Preset()
    assert preset.get("generation.threshold") == 0.296
    assert preset.get("shading") is preset.shading
    assert preset.get("name") == "paper-default"
    with pytest.raises(PresetError, match="unknown field"):
        preset.get("generation.nope")


def test_the_largest_facets_are_never_wider_than_a_grain():
    preset = Preset()
    # paper-default's scale: grains 2.5 mm apart, so the 200 µm facets are the preset's.
    assert preset.grain_spacing_m == pytest.approx(1.0 / (8.0 * 36.0 * math.sqrt(2.0)))
    assert preset.largest_facet_m == pytest.approx(200e-6)
    # 10 000 tiles per metre of 256 cells: grains 0.28 µm apart; 1 mm facets would be 3600
    # grains wide, so the grain's width bounds them.
    tiny = preset.replace(**{"shading.uv_scale": 10_000.0, "generation.period": 256,
                             "shading.facet_size": 1000.0})  # fmt: skip
    assert tiny.largest_facet_m == pytest.approx(tiny.grain_spacing_m)
    assert tiny.largest_facet_m < 1e-6
    # At the crossing the two agree, and the bound moves with either field.
    for uv_scale in (0.01, 1.0, 50.0, 1000.0):
        p = preset.replace(**{"shading.uv_scale": uv_scale})
        assert p.largest_facet_m == pytest.approx(min(200e-6, p.grain_spacing_m))
