import json
import os
import stat

import pytest

from sand_editor.preset import Preset, PresetError
from sand_editor.preset import _io as preset_io


def _document(**changes):
    """The default document with dotted-path changes; a value of ... deletes the key."""
    document = Preset().to_dict()
    for path, value in changes.items():
        *parents, key = path.split(".")
        owner = document
        for parent in parents:
            owner = owner[parent]
        if value is ...:
            del owner[key]
        else:
            owner[key] = value
    return json.dumps(document)


BAD_CONTENT = [
    pytest.param(b"\xff\xfe{}", ["not UTF-8"], id="not-utf8"),
    pytest.param('{\n  "format": ', ["not valid JSON", "line 2, column"], id="malformed"),
    pytest.param("[1, 2]", ["top level is an array"], id="top-level-array"),
    pytest.param("", ["not valid JSON", "line 1, column 1"], id="empty"),
    pytest.param("[" * 100_000 + "]" * 100_000, ["not valid JSON"], id="deeply-nested"),
    pytest.param(_document(format="other"), ["format", "'sand-editor-preset'"], id="format"),
    pytest.param(_document(format=...), ["format: missing"], id="format-missing"),
    pytest.param(_document(schema_version=...), ["schema_version: missing"], id="no-version"),
    pytest.param(_document(schema_version="2"), ["schema_version", "a string"], id="version-str"),
    pytest.param(_document(schema_version=2.0), ["schema_version", "a number"], id="version-flt"),
    pytest.param(_document(schema_version=0), ["schema_version", "1 to 3"], id="version-0"),
    pytest.param(
        _document(schema_version=4),
        [
            "schema_version: written by a newer Sand Editor: schema version 4, "
            "this version reads up to 3"
        ],
        id="version-newer",
    ),
    pytest.param(
        _document(**{"generation.threshold": "0.3"}),
        ["generation.threshold", "a string"],
        id="threshold-string",
    ),
    pytest.param(
        _document(**{"generation.threshold": 1.7}),
        ["generation.threshold: 1.7 is out of range; allowed 0 to 1"],
        id="threshold-range",
    ),
    pytest.param(
        _document(**{"generation.layers": 3.0}),
        ["generation.layers", "an integer"],
        id="layers-float",
    ),
    pytest.param(
        _document(**{"generation.layers": None}), ["generation.layers", "null"], id="layers-null"
    ),
    pytest.param(_document(**{"shading.sss": True}), ["shading.sss", "a boolean"], id="bool"),
    pytest.param(
        _document(**{"generation.treshold": 0.3}),
        ["generation.treshold", "unknown field", "did you mean 'threshold'", "layers"],
        id="unknown-section-field",
    ),
    pytest.param(
        _document(colour="#ffffff"),
        ["colour", "unknown field", "generation"],
        id="unknown-top-field",
    ),
    pytest.param(
        _document().replace('"threshold": 0.296', '"threshold": NaN'),
        ["generation.threshold", "finite numbers only"],
        id="nan",
    ),
    pytest.param(
        _document().replace('"sss": 0.733', '"sss": -Infinity'),
        ["shading.sss", "finite numbers only"],
        id="infinity",
    ),
    pytest.param(
        _document().replace('"sss": 0.733', '"sss": 1e999'),
        ["shading.sss", "finite numbers only"],
        id="overflow",
    ),
    pytest.param(
        _document(**{"generation.weights": [0, 0, 0, 0]}),
        ["generation.weights", "at least one above 0"],
        id="weights-zero",
    ),
    pytest.param(
        _document(**{"generation.weights": [1, 2, 3]}),
        ["generation.weights", "exactly 4"],
        id="weights-count",
    ),
    pytest.param(
        _document(**{"generation.weights": [1, -2, 3, 4]}),
        ["generation.weights[1]", "allowed 0 to 100"],
        id="weights-range",
    ),
    pytest.param(
        _document(**{"generation.colors": ["#ffffff"] * 5}),
        ["generation.colors", "exactly 4"],
        id="colors-count",
    ),
    pytest.param(
        _document(**{"generation.colors": ["#ffffff", "white", "#000000", "#000000"]}),
        ["generation.colors[1]", "#rrggbb"],
        id="colors-name",
    ),
    pytest.param(
        _document(**{"generation.base_color": "#fff"}),
        ["generation.base_color", "#rrggbb"],
        id="base-color-short",
    ),
    pytest.param(
        _document(**{"shading.grain_ior": 3}), ["shading.grain_ior", "allowed 1.3 to 2.5"], id="ior"
    ),
    pytest.param(_document(generation=[1]), ["generation", "allowed an object"], id="section"),
    pytest.param(_document(name=""), ["name", "allowed 1 to 80"], id="name-empty"),
    pytest.param('{"format": "a", "format": "b"}', ["'format' appears twice"], id="duplicate"),
]


@pytest.mark.parametrize(("content", "expected"), BAD_CONTENT)
def test_bad_files_raise_preset_error_naming_file_and_field(tmp_path, content, expected):
    path = tmp_path / "broken-sand.json"
    if isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    else:
        path.write_bytes(content)
    with pytest.raises(PresetError) as caught:
        Preset.load(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: ")
    for part in expected:
        assert part in message


def test_missing_file(tmp_path):
    path = tmp_path / "nowhere.json"
    with pytest.raises(PresetError, match="nowhere.json: no such file"):
        Preset.load(path)


def test_folder_instead_of_file(tmp_path):
    with pytest.raises(PresetError, match="is a folder"):
        Preset.load(tmp_path)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads all")
def test_unreadable_file(tmp_path):
    path = tmp_path / "secret.json"
    path.write_text(_document(), encoding="utf-8")
    path.chmod(0)
    with pytest.raises(PresetError, match="secret.json: cannot read"):
        Preset.load(path)


def test_huge_file_is_refused_by_its_size_before_reading(tmp_path):
    path = tmp_path / "huge.json"
    with open(path, "wb") as stream:
        stream.truncate(2**30)  # sparse: no gigabyte is written or read
    with pytest.raises(PresetError) as caught:
        Preset.load(path)
    # The size comes from stat; reading would report the bytes it read instead.
    assert str(caught.value) == (
        f"{path}: the file is 1073741824 bytes; presets are limited to 1 MiB (1048576 bytes)"
    )


def test_file_just_under_the_limit_is_read(tmp_path):
    text = _document()
    path = tmp_path / "padded.json"
    path.write_text(text[:-1] + " " * (preset_io.MAX_FILE_BYTES - len(text)) + "}")
    assert path.stat().st_size == preset_io.MAX_FILE_BYTES
    assert Preset.load(path) == Preset()


def test_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + _document().encode())
    assert Preset.load(path) == Preset()


def test_saved_file_layout(tmp_path):
    path = tmp_path / "out.json"
    preset = Preset(name="Grès rouge", description="two\nlines")
    preset.save(path)
    text = path.read_bytes().decode("utf-8")
    assert text.endswith("}\n") and not text.endswith("\n\n")
    assert text.startswith('{\n  "format": "sand-editor-preset",\n  "schema_version": 3,\n')
    assert '"name": "Grès rouge"' in text
    assert '    "weights": [22, 18, 56, 4],\n' in text
    assert list(json.loads(text)) == [
        "format",
        "schema_version",
        "name",
        "description",
        "generation",
        "shading",
    ]
    assert Preset.load(path) == preset
    # Not the private mode temporary files are created with.
    assert stat.S_IMODE(path.stat().st_mode) == 0o644


def _break_replace(monkeypatch):
    def fail(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)


def _break_fsync(monkeypatch):
    def fail(*args):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(os, "fsync", fail)


def _break_json(monkeypatch):
    def fail(*args, **kwargs):
        raise TypeError("cannot serialise")

    monkeypatch.setattr(preset_io.json, "dumps", fail)


@pytest.mark.parametrize("break_it", [_break_replace, _break_fsync, _break_json])
def test_failed_save_leaves_the_old_file_and_no_temporary_file(tmp_path, monkeypatch, break_it):
    path = tmp_path / "sand.json"
    Preset().save(path)
    before = path.read_bytes()
    break_it(monkeypatch)
    with pytest.raises(PresetError) as caught:
        Preset(name="changed").save(path)
    monkeypatch.undo()
    assert str(caught.value).startswith(f"{path}: cannot save")
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["sand.json"]


def test_save_into_a_missing_folder(tmp_path):
    path = tmp_path / "missing" / "sand.json"
    with pytest.raises(PresetError, match="does not exist") as caught:
        Preset().save(path)
    assert str(path) in str(caught.value)
    assert os.listdir(tmp_path) == []


def test_save_over_a_folder_leaves_nothing_behind(tmp_path):
    (tmp_path / "sand.json").mkdir()
    with pytest.raises(PresetError, match="sand.json: is a folder; allowed a regular file"):
        Preset().save(tmp_path / "sand.json")
    assert os.listdir(tmp_path) == ["sand.json"]


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes all")
def test_save_into_a_read_only_folder(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        with pytest.raises(PresetError, match="cannot save"):
            Preset().save(folder / "sand.json")
        assert os.listdir(folder) == []
    finally:
        folder.chmod(stat.S_IRWXU)


def test_save_keeps_the_permissions_of_the_replaced_file(tmp_path):
    path = tmp_path / "sand.json"
    Preset().save(path)
    path.chmod(0o640)
    Preset(name="again").save(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o640


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_named_pipe_is_refused_without_blocking(tmp_path):
    path = tmp_path / "pipe.json"
    os.mkfifo(path)
    with pytest.raises(PresetError, match="pipe.json: is not a regular file"):
        Preset.load(path)
