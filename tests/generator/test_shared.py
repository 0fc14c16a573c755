"""Tiles handed between processes in shared memory: exact round trip, the segment outlives its
readers, and a segment that is missing, short or holds what no generator makes is refused with
one ``ValueError`` naming why."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sand_editor.generator import SandTextures
from sand_editor.generator.shared import LAYOUT, SharedTile, read_shared, tile_bytes

SIZE = 64


@pytest.fixture(scope="module")
def tile(gl_ctx):
    from sand_editor.generator import generate
    from sand_editor.preset import Preset

    preset = Preset()
    return preset, generate(preset, SIZE, ctx=gl_ctx)


def _arrays(textures: SandTextures) -> dict[str, np.ndarray]:
    return {name: getattr(textures, name) for name, _, _ in LAYOUT}


def test_a_tile_comes_back_bit_for_bit_with_the_generation_it_is_given(tile):
    preset, textures = tile
    shared = SharedTile(textures)
    try:
        back = read_shared(shared.name, SIZE, preset.generation)
    finally:
        shared.close()
    assert back.generation == preset.generation
    for name, array in _arrays(textures).items():
        got = getattr(back, name)
        assert got.dtype == array.dtype and np.array_equal(got, array), name
    assert np.array_equal(back.average_albedo, textures.average_albedo)
    with pytest.raises(ValueError, match="no shared tile"):  # closing unlinked it
        read_shared(shared.name, SIZE, preset.generation)


def test_the_segment_outlives_a_reader_process_and_goes_when_its_maker_closes_it(tile):
    """Python before 3.13 has a reader's resource tracker unlink the segment when the reader
    exits (cpython#82300): the editor's tile would vanish with the first viewer that read it."""
    preset, textures = tile
    shared = SharedTile(textures)
    try:
        code = (
            "from sand_editor.generator.shared import read_shared; "
            f"t = read_shared({shared.name!r}, {SIZE}, None); print(int(t.grain_id.sum()))"
        )
        for _ in range(2):
            result = subprocess.run(
                [sys.executable, "-c", code], capture_output=True, text=True, timeout=60
            )
            assert result.returncode == 0, result.stderr
            assert int(result.stdout) == int(textures.grain_id.sum())
            assert "leaked" not in result.stderr, result.stderr
        read_shared(shared.name, SIZE, preset.generation)  # still there
    finally:
        shared.close()
    with pytest.raises(ValueError, match="no shared tile"):
        read_shared(shared.name, SIZE, preset.generation)
    shared.close()  # twice is harmless


def _spoilt(textures: SandTextures, name: str, value) -> SandTextures:
    arrays = {k: v.copy() for k, v in _arrays(textures).items()}
    arrays[name].reshape(-1)[arrays[name].size // 3] = value
    return SandTextures(**arrays, generation=textures.generation)


@pytest.mark.parametrize(
    "name,value,reason",
    [
        ("normal", np.nan, "normal holds values that are not finite"),
        ("height", np.inf, "height holds values that are not finite"),
        ("albedo", 1.5, r"albedo leaves \[0, 1\]"),
        ("glint", -0.25, r"glint leaves \[0, 1\]"),
        ("height", -1.0, "height leaves"),
        ("normal", 3.0, "normals are not unit vectors"),
        ("layer", 99, "layers leave -1"),
    ],
)
def test_values_no_generator_makes_are_refused(tile, name, value, reason):
    preset, textures = tile
    shared = SharedTile(_spoilt(textures, name, value))
    try:
        with pytest.raises(ValueError, match=reason):
            read_shared(shared.name, SIZE, preset.generation)
    finally:
        shared.close()


def test_a_short_segment_and_a_wrong_size_are_refused(tile):
    preset, textures = tile
    shared = SharedTile(textures)
    try:
        with pytest.raises(ValueError, match=f"has {tile_bytes(SIZE)} bytes"):
            read_shared(shared.name, 2 * SIZE, preset.generation)
        with pytest.raises(ValueError, match="pixels wide, not 100"):
            read_shared(shared.name, 100, preset.generation)
    finally:
        shared.close()
    small = SandTextures(**{k: v[:48, :48] for k, v in _arrays(textures).items()})
    with pytest.raises(ValueError, match="tiles of 48² are not shared"):
        SharedTile(small)


@settings(max_examples=300, deadline=None, database=None)
@given(name=st.text(max_size=80), size=st.integers(-5, 5000))
def test_any_name_and_size_give_a_tile_or_one_value_error(name, size):
    try:
        read_shared(name, size, None)
    except ValueError as exc:
        assert "\n" not in str(exc)
    else:  # pragma: no cover - no segment of that name exists here
        pytest.fail(f"read a tile named {name!r}")
