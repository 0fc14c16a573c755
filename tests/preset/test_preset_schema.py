import copy
import json
from pathlib import Path

import pytest

from sand_editor.preset import MIGRATIONS, SCHEMA_VERSION, Preset, PresetError

PRESETS = sorted((Path(__file__).resolve().parents[2] / "presets").glob("*.json"))
# The shipped presets as schema 2 released them: files people have.
SCHEMA_2 = sorted((Path(__file__).resolve().parent / "data").glob("*-schema2.json"))


def _flatten_to_v1(document):
    """Schema 1: the section fields sat at the top level."""
    flat = {key: value for key, value in document.items() if key not in ("generation", "shading")}
    flat.update(document["generation"])
    flat.update(document["shading"])
    flat["schema_version"] = 1
    return flat


def test_every_older_version_has_a_migration():
    assert sorted(MIGRATIONS) == list(range(1, SCHEMA_VERSION))


@pytest.mark.parametrize("path", SCHEMA_2, ids=lambda path: path.stem)
def test_v1_flat_file_loads_as_the_same_preset(tmp_path, path):
    v2 = json.loads(path.read_text(encoding="utf-8"))
    v1_path = tmp_path / "old.json"
    v1_path.write_text(json.dumps(_flatten_to_v1(v2)), encoding="utf-8")
    assert Preset.load(v1_path) == Preset.load(path)


def test_migrations_leave_their_input_alone():
    v2 = json.loads(SCHEMA_2[0].read_text(encoding="utf-8"))
    v1 = _flatten_to_v1(v2)
    for version, document in ((1, v1), (2, v2)):
        before = copy.deepcopy(document)
        migrated = MIGRATIONS[version](document)
        assert document == before
        assert migrated["schema_version"] == version + 1
    migrated = MIGRATIONS[1](v1)
    assert migrated["generation"]["threshold"] == v2["generation"]["threshold"]
    assert "threshold" not in migrated


def test_schema_2_paper_default_is_the_shipped_one():
    # The look of the reference's material survives the move to the facet model.
    # The shipped one blends close and far at the reference shader's default distance rather
    # than its saved material's, and says so.
    old = Preset.load(Path(__file__).resolve().parent / "data" / "paper-default-schema2.json")
    shipped = Preset.load(PRESETS[[p.stem for p in PRESETS].index("paper-default")])
    assert (old.shading.sigmoid_a, old.shading.sigmoid_b) == (2.0, 0.0)
    assert (shipped.shading.sigmoid_a, shipped.shading.sigmoid_b) == (3.0, 2.0)
    blend = {"shading.sigmoid_a": 3.0, "shading.sigmoid_b": 2.0, "description": shipped.description}
    assert old.replace(**blend) == shipped


@pytest.mark.parametrize("path", SCHEMA_2, ids=lambda path: path.stem)
def test_schema_2_glints_map_onto_facets(path):
    old = json.loads(path.read_text(encoding="utf-8"))["shading"]
    shading = Preset.load(path).shading
    # A Phong lobe of exponent Gs is a Beckmann distribution of α = 1/√(2·Gs).
    assert shading.facet_roughness == pytest.approx((2 * old["glint_shininess"]) ** -0.5, rel=2e-3)
    assert 0.0 <= shading.clear_grains <= 1.0
    assert shading.grain_ior == 1.458
    assert shading.sss == old["sss"] and shading.uv_scale == old["uv_scale"]


@pytest.mark.parametrize(
    ("mu", "share"),
    [(2.0, 1.0), (10.0, 0.0), (-10.0, 0.0), (3.0, pytest.approx(1.2e-7, rel=0.05))],
)
def test_selection_far_from_the_grains_means_fewer_clear_grains(mu, share):
    shading = {"glint_mu": mu, "glint_sigma": 0.277, "glint_shininess": 10.4}
    document = {"format": "sand-editor-preset", "schema_version": 2, "shading": shading}
    assert Preset.from_dict(document).shading.clear_grains == share


@pytest.mark.parametrize(
    ("field", "value"),
    [("glint_mu", "2"), ("glint_sigma", 0.0), ("glint_shininess", float("nan")), ("glint_mu", 11)],
)
def test_bad_schema_2_glint_values_are_named(field, value):
    document = {"format": "sand-editor-preset", "schema_version": 2, "shading": {field: value}}
    with pytest.raises(PresetError, match=rf"old.json: shading\.{field} \(schema 2\)"):
        Preset.from_dict(document, source="old.json")


def test_schema_2_fields_that_are_gone_are_dropped_and_unknown_ones_reported():
    document = {"format": "sand-editor-preset", "schema_version": 2,
                "shading": {"sample_count": 7, "fresnel_roughness": 0.8, "sss": 0.5}}  # fmt: skip
    assert Preset.from_dict(document).shading.sss == 0.5
    document["shading"]["glint_muu"] = 1
    with pytest.raises(PresetError, match="shading.glint_muu: unknown field"):
        Preset.from_dict(document)


def test_v1_unknown_field_is_reported_after_migration():
    v1 = _flatten_to_v1(json.loads(SCHEMA_2[0].read_text(encoding="utf-8")))
    v1["treshold"] = 0.3
    with pytest.raises(PresetError, match="old.json: treshold: unknown field"):
        Preset.from_dict(v1, source="old.json")


def test_newer_schema_is_refused():
    document = Preset().to_dict()
    document["schema_version"] = SCHEMA_VERSION + 1
    with pytest.raises(PresetError, match="newer Sand Editor: schema version 4"):
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
