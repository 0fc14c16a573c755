import json
from pathlib import Path

import pytest

from sand_editor.preset import Preset

PRESETS_DIR = Path(__file__).resolve().parents[2] / "presets"
SHIPPED = ["paper-default", "pale-quartz", "black-volcanic", "red-desert"]


def _load(name):
    return Preset.load(PRESETS_DIR / f"{name}.json")


def test_exactly_the_expected_presets_ship():
    assert sorted(path.stem for path in PRESETS_DIR.glob("*.json")) == sorted(SHIPPED)


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_preset_loads_with_its_name_and_a_description(name):
    preset = _load(name)
    assert preset.name == name
    assert len(preset.description) >= 40


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_preset_round_trips_byte_for_byte(tmp_path, name):
    preset = _load(name)
    preset.save(tmp_path / "copy.json")
    assert Preset.load(tmp_path / "copy.json") == preset
    # Shipped files are written in the canonical layout, so saving changes nothing.
    assert (tmp_path / "copy.json").read_bytes() == (PRESETS_DIR / f"{name}.json").read_bytes()


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_files_spell_out_every_field(name):
    # A shipped preset must not silently follow a future change of a default.
    document = json.loads((PRESETS_DIR / f"{name}.json").read_text(encoding="utf-8"))
    assert document == _load(name).to_dict()


def test_paper_default_is_the_defaults():
    assert _load("paper-default").replace(description="") == Preset()


def test_shipped_presets_differ_in_palette_threshold_and_seed():
    presets = [_load(name).generation for name in SHIPPED]
    for attribute in ("colors", "base_color", "threshold", "seed"):
        values = [getattr(generation, attribute) for generation in presets]
        assert len(set(values)) == len(values), attribute


def _mean_luminance(generation):
    total = sum(generation.weights)
    return sum(
        weight
        / total
        * sum(c * w for c, w in zip(color.linear, (0.2126, 0.7152, 0.0722), strict=True))
        for color, weight in zip(generation.colors, generation.weights, strict=True)
    )


def test_palettes_match_their_sands():
    brightness = {name: _mean_luminance(_load(name).generation) for name in SHIPPED}
    assert brightness["black-volcanic"] < 0.1 < brightness["red-desert"] < brightness["pale-quartz"]
    red = _load("red-desert").generation
    assert all(color.r > color.b for color in red.colors)
    volcanic = _load("black-volcanic")
    # Volcanic glass: glassier facets (sharper glints) and a higher index than quartz.
    assert volcanic.shading.facet_roughness < _load("paper-default").shading.facet_roughness
    assert volcanic.shading.grain_ior > _load("pale-quartz").shading.grain_ior
    # Iron-oxide coatings: few clear grains, dull sheen.
    red = _load("red-desert").shading
    assert red.clear_grains < volcanic.shading.clear_grains and red.facet_roughness > 0.3
