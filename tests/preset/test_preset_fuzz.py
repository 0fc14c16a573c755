"""Hostile preset documents: the loader answers PresetError (one line, at most 300 characters)
or a valid preset that round-trips, and nothing else, whatever the file holds."""

from __future__ import annotations

import json
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sand_editor.preset import FIELDS, Preset, PresetError
from sand_editor.preset._errors import MAX_MESSAGE_CHARS
from sand_editor.resources import bundled_preset

# Documents per strategy: 1 000 in the suite; SAND_EDITOR_FUZZ_EXAMPLES=12500 makes the four
# strategies 50 000 documents. No example database: the suite writes nothing into the checkout.
FUZZ = settings(
    max_examples=int(os.environ.get("SAND_EDITOR_FUZZ_EXAMPLES", "1000")),
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

VALID = Preset.load(bundled_preset("paper-default")).to_dict()
KEYS = ["format", "schema_version", "name", "description", "generation", "shading"]
KEYS += [spec.name for spec in FIELDS] + ["", "x\ny", "\x1b[31m", "\u2028", "a" * 500]

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=40),
    st.sampled_from(["#ffd7c4", "#FFF", "#gggggg", "ffd7c4", "#ffd7c4\n", "#ffd7c4 "]),
)
json_values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=6),
        st.dictionaries(st.sampled_from(KEYS) | st.text(max_size=12), inner, max_size=6),
    ),
    max_leaves=30,
)


def _set(document: dict, path: list[str], value) -> dict:
    document = json.loads(json.dumps(document))
    target = document
    for key in path[:-1]:
        if not isinstance(target.get(key), dict):
            target[key] = {}
        target = target[key]
    target[path[-1]] = value
    return document


field_paths = st.sampled_from([spec.path.split(".") for spec in FIELDS] + [[k] for k in KEYS])
mutated = st.one_of(
    st.builds(_set, st.just(VALID), field_paths, json_values),
    st.builds(
        lambda doc, version: {**doc, "schema_version": version},
        st.just(VALID),
        st.integers(-3, 5) | st.floats() | st.text(max_size=3),
    ),
    st.builds(
        lambda doc, drop: {k: v for k, v in doc.items() if k != drop},
        st.just(VALID),
        st.sampled_from(list(VALID)),
    ),
)


def _hostile_text(kind: str, size: int) -> str:
    if kind == "deep":
        return '{"format": "sand-editor-preset", "schema_version": 2, "name": ' + "[" * size
    if kind == "deeper":
        return "[" * size + "]" * size
    if kind == "digits":
        return '{"format": "sand-editor-preset", "schema_version": 2, "seed": ' + "9" * size + "}"
    if kind == "float-digits":
        return f'{{"format": "sand-editor-preset", "schema_version": 2, "sss": 0.{"1" * size}}}'
    if kind == "exponent":
        return f'{{"format": "sand-editor-preset", "schema_version": 2, "sss": 1e{size}}}'
    return '{"format": "sand-editor-preset", "schema_version": 2, "' + "k" * size + '": 1}'


hostile_texts = st.builds(
    _hostile_text,
    st.sampled_from(["deep", "deeper", "digits", "float-digits", "exponent", "key"]),
    st.integers(1, 120_000),
)


def _check(load) -> None:
    try:
        preset = load()
    except PresetError as error:
        message = str(error)
        assert "\n" not in message and "\r" not in message, message
        assert len(message) <= MAX_MESSAGE_CHARS, message
        assert message.isprintable(), message
        return
    # Anything accepted is valid and survives a save and a load unchanged.
    again = Preset.from_dict(json.loads(json.dumps(preset.to_dict())))
    assert again == preset


@FUZZ
@given(document=json_values)
def test_any_json_value_gives_preset_error_or_a_valid_preset(document):
    _check(lambda: Preset.from_dict(document))


@FUZZ
@given(document=mutated)
def test_a_shipped_preset_with_any_field_replaced(document):
    _check(lambda: Preset.from_dict(document))


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz") / "preset.json"


@FUZZ
@given(data=st.binary(max_size=300) | hostile_texts.map(str.encode))
def test_any_file_bytes(scratch, data):
    scratch.write_bytes(data)
    _check(lambda: Preset.load(scratch))


@FUZZ
@given(
    document=mutated,
    indent=st.sampled_from([None, 2]),
    insert=st.sampled_from(["", "\ufeff", "\x00", "\xff", "NaN", "}", "//"]),
    at=st.integers(0, 2000),
)
def test_a_shipped_preset_file_with_bytes_changed(scratch, document, indent, insert, at):
    text = json.dumps(document, indent=indent, ensure_ascii=False)
    at = min(at, len(text))
    scratch.write_bytes((text[:at] + insert + text[at:]).encode("utf-8", "surrogatepass"))
    _check(lambda: Preset.load(scratch))


@pytest.mark.parametrize(
    "name", ["a\0b", "", "/", "/dev/null", "/proc/self/mem", "x" * 5000, "/tmp/\udcff"]
)
def test_odd_file_names_give_preset_error(name):
    with pytest.raises(PresetError) as caught:
        Preset.load(name)
    assert len(str(caught.value)) <= MAX_MESSAGE_CHARS and "\n" not in str(caught.value)


def test_numbers_past_pythons_digit_limit_name_the_file(tmp_path):
    path = tmp_path / "big.json"
    path.write_text(
        '{"format": "sand-editor-preset", "schema_version": 2, "seed": 1' + "0" * 4400 + "}"
    )
    with pytest.raises(PresetError, match=r"big\.json: a number of 4401 characters"):
        Preset.load(path)


def test_a_key_with_newlines_stays_one_escaped_line(tmp_path):
    path = tmp_path / "forged.json"
    key = "x\nTraceback (most recent call last):\n" + "y" * 100_000
    path.write_text(json.dumps({"format": "sand-editor-preset", "schema_version": 2, key: 1}))
    with pytest.raises(PresetError) as caught:
        Preset.load(path)
    message = str(caught.value)
    assert "\n" not in message and "x\\nTraceback" in message
    assert len(message) <= MAX_MESSAGE_CHARS


@pytest.mark.parametrize("section", ["generation", "shading"])
def test_schema_1_label_on_a_sectioned_body_is_refused_not_reset(tmp_path, section):
    path = tmp_path / "mislabelled.json"
    other = "shading" if section == "generation" else "generation"
    body = {k: v for k, v in VALID.items() if k != other}
    path.write_text(json.dumps({**body, "schema_version": 1}))
    with pytest.raises(PresetError, match=f"schema_version: is 1, but the file has a '{section}'"):
        Preset.load(path)
    stray = tmp_path / "stray.json"
    stray.write_text(json.dumps({"format": "sand-editor-preset", "schema_version": 1,
                                 "threshold": 0.4, section: "garbage"}))  # fmt: skip
    with pytest.raises(PresetError, match=f"has a '{section}' section"):
        Preset.load(stray)


def test_schema_1_files_still_migrate_with_their_values(tmp_path):
    path = tmp_path / "v1.json"
    path.write_text(json.dumps({"format": "sand-editor-preset", "schema_version": 1,
                                "threshold": 0.41, "sss": 0.5}))  # fmt: skip
    preset = Preset.load(path)
    assert preset.generation.threshold == 0.41 and preset.shading.sss == 0.5


def test_deep_nesting_is_refused_without_recursing():
    document = current = {}
    for _ in range(100_000):  # far past Python's recursion limit
        current["name"] = current = {}
    with pytest.raises(PresetError, match="nested more than 8 deep"):
        Preset.from_dict({"format": "sand-editor-preset", "schema_version": 2, "x": document})
