import copy
import json
from pathlib import Path

import pytest

from sand_editor.preset import MIGRATIONS, SCHEMA_VERSION, Preset, PresetError

PRESETS = sorted((Path(__file__).resolve().parents[2] / "presets").glob("*.json"))


def _flatten_to_v1(document):
    """Schema 1: the section fields sat at the top level."""
    flat = {key: value for key, value in document.items() if key not in ("generation", "shading")}
    flat.update(document["generation"])
    flat.update(document["shading"])
    flat["schema_version"] = 1
    return flat


def test_every_older_version_has_a_migration():
    assert sorted(MIGRATIONS) == list(range(1, SCHEMA_VERSION))


@pytest.mark.parametrize("path", PRESETS, ids=lambda path: path.stem)
def test_v1_flat_file_loads_as_the_same_preset(tmp_path, path):
    v2 = json.loads(path.read_text(encoding="utf-8"))
    v1_path = tmp_path / "old.json"
    v1_path.write_text(json.dumps(_flatten_to_v1(v2)), encoding="utf-8")
    assert Preset.load(v1_path) == Preset.load(path)


def test_migration_leaves_its_input_alone():
    v1 = _flatten_to_v1(Preset().to_dict())
    before = copy.deepcopy(v1)
    migrated = MIGRATIONS[1](v1)
    assert v1 == before
    assert migrated["schema_version"] == 2
    assert migrated["generation"]["threshold"] == 0.296
    assert "threshold" not in migrated


def test_v1_unknown_field_is_reported_after_migration():
    v1 = _flatten_to_v1(Preset().to_dict())
    v1["treshold"] = 0.3
    with pytest.raises(PresetError, match="old.json: treshold: unknown field"):
        Preset.from_dict(v1, source="old.json")


def test_newer_schema_is_refused():
    document = Preset().to_dict()
    document["schema_version"] = SCHEMA_VERSION + 1
    with pytest.raises(PresetError, match="newer Sand Editor: schema version 3"):
        Preset.from_dict(document)


def test_missing_fields_take_their_defaults():
    document = {
        "format": "sand-editor-preset",
        "schema_version": 2,
        "generation": {"threshold": 0.5},
    }
    assert Preset.from_dict(document) == Preset().replace(**{"generation.threshold": 0.5})


def test_to_dict_is_plain_json_and_round_trips():
    preset = Preset(description="x").replace(**{"generation.weights": (1.5, 0, 0, 2)})
    document = preset.to_dict()
    assert json.loads(json.dumps(document, allow_nan=False)) == document
    assert document["generation"]["weights"] == [1.5, 0, 0, 2]
    assert Preset.from_dict(document) == preset


def test_from_dict_names_its_source():
    document = Preset().to_dict()
    document["shading"]["sss"] = 11
    with pytest.raises(PresetError) as caught:
        Preset.from_dict(document, source="mine.json")
    assert str(caught.value) == "mine.json: shading.sss: 11 is out of range; allowed 0 to 10"
