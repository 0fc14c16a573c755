"""The bake command: files, encodings, material record, atomicity, and clear errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sand_editor.bake import FILES, bake
from sand_editor.colour import linear_to_srgb
from sand_editor.generator import generate
from sand_editor.preset import Preset

pytestmark = pytest.mark.gl


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "sand_editor", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
    )


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    out = tmp_path_factory.mktemp("bake")
    preset = Preset().replace(**{"generation.seed": 5})
    record = bake(preset, 128, out)
    return preset, record, out


def test_bake_writes_every_file_with_its_encoding(baked):
    _, _, out = baked
    assert {p.name for p in out.iterdir()} == set(FILES) | {"material.json"}
    modes = {
        "albedo.png": ("RGB", 128),
        "albedo_low.png": ("RGB", 64),
        "normal.png": ("RGB", 128),
        "height.png": ("I;16", 128),
        "glint.png": ("L", 128),
        "layer.png": ("L", 128),
    }
    for name, (mode, size) in modes.items():
        with Image.open(out / name) as image:
            assert image.mode == mode, name
            assert image.size == (size, size), name


def test_baked_pixels_encode_the_textures(baked):
    preset, _, out = baked
    tex = generate(preset, 128)
    # Image rows run top-down (v = 1 first); arrays keep row 0 at v = 0.
    albedo = np.asarray(Image.open(out / "albedo.png"))[::-1]
    expected = np.rint(linear_to_srgb(tex.albedo) * 255)
    assert np.abs(albedo.astype(int) - expected).max() <= 1
    normal = np.asarray(Image.open(out / "normal.png"))[::-1].astype(np.float64) / 255 * 2 - 1
    cos = np.sum(normal * tex.normal, axis=-1) / np.linalg.norm(normal, axis=-1)
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 1.0
    height = np.asarray(Image.open(out / "height.png"))[::-1] / 65535.0
    assert np.abs(height - tex.height).max() <= 1 / 65535
    layer = np.asarray(Image.open(out / "layer.png"))[::-1].astype(int) - 1
    np.testing.assert_array_equal(layer, tex.layer)
    glint = np.asarray(Image.open(out / "glint.png"))[::-1] / 255.0
    assert (glint[tex.layer != 0] == 0).all()


def test_material_record(baked):
    preset, record, out = baked
    on_disk = json.loads((out / "material.json").read_text(encoding="utf-8"))
    assert on_disk == record
    assert Preset.from_dict(on_disk["preset"]) == preset
    stats = on_disk["statistics"]
    assert len(stats["coverage_per_layer"]) == preset.generation.layers
    assert sum(stats["coverage_per_layer"]) + stats["gap_fraction"] == pytest.approx(1.0)
    assert stats["grain_count"] > stats["top_layer_grain_count"] > 0
    tex = generate(preset, 128)
    np.testing.assert_allclose(on_disk["average_albedo_linear"], tex.average_albedo, atol=1e-6)
    assert (
        on_disk["average_albedo_srgb"].startswith("#") and len(on_disk["average_albedo_srgb"]) == 7
    )


def test_bake_command_line(tmp_path):
    out = tmp_path / "nested" / "out"
    result = run_cli("bake", "red-desert", "--size", "64", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "red-desert" in result.stdout
    assert (out / "material.json").is_file()
    assert json.loads((out / "material.json").read_text())["size"] == 64


def test_the_bake_line_shows_the_out_folder_escaped_on_one_line(tmp_path):
    out = tmp_path / "a\nb\x1b]0;title\x07"
    result = run_cli("bake", "red-desert", "--size", "64", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert result.stdout.count("\n") == 1 and "\x1b" not in result.stdout
    assert "a\\nb\\x1b]0;title\\x07: top-layer" in result.stdout
    assert (out / "material.json").is_file()


@pytest.mark.parametrize(
    ("content", "fragment"),
    [
        ('{"format": "sand-editor-preset", "schema_version": 2,', "not valid JSON"),
        (
            '{"format": "sand-editor-preset", "schema_version": 2, "generation": {"threshold": 7}}',
            "generation.threshold",
        ),
    ],
)
def test_bad_preset_gives_one_line_and_no_traceback(tmp_path, content, fragment):
    preset = tmp_path / "broken.json"
    preset.write_text(content, encoding="utf-8")
    out = tmp_path / "out"
    result = run_cli("bake", str(preset), "--size", "64", "--out", str(out))
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "broken.json" in lines[0] and fragment in lines[0]
    assert "Traceback" not in result.stderr
    assert not out.exists(), "nothing may be written for a preset that does not load"


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["bake", "no-such-preset", "--size", "64"], "no-such-preset"),
        (["bake", "paper-default", "--size", "20"], "allowed 64 to 4096"),
    ],
)
def test_bad_arguments_are_one_clear_line(tmp_path, args, fragment):
    result = run_cli(*args, "--out", str(tmp_path / "o"))
    assert result.returncode == 1
    assert fragment in result.stderr and "Traceback" not in result.stderr


def test_a_failed_bake_keeps_the_previous_bake(tmp_path, monkeypatch):
    out = tmp_path / "out"
    bake(Preset(), 64, out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    # The disk fills up while the fourth file is being written (fsync reports it).
    calls = []
    real_fsync = os.fsync

    def filling_fsync(fd):
        calls.append(fd)
        if len(calls) == 4:
            raise OSError(28, "No space left on device")
        return real_fsync(fd)

    monkeypatch.setattr(os, "fsync", filling_fsync)
    with pytest.raises(OSError, match="No space left"):
        bake(Preset().replace(**{"generation.seed": 9}), 64, out)
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after == before, "the previous bake must be intact, with no temporary files left"
