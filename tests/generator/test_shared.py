"""Tiles handed between processes in shared memory: exact round trip, the segment outlives its
readers, and a segment that is missing, short, shrinking, no regular file or holds what no
generator makes is refused with one ``ValueError`` naming why."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
import uuid
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sand_editor.generator import SandTextures
from sand_editor.generator.shared import (
    LAYOUT,
    MAX_HEIGHT,
    SEGMENT_FOLDER,
    SharedTile,
    read_shared,
    tile_bytes,
)

SIZE = 64
REPO = Path(__file__).resolve().parents[2]
needs_dev_shm = pytest.mark.skipif(
    not os.path.isdir(SEGMENT_FOLDER), reason=f"segments are read from {SEGMENT_FOLDER}"
)


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
        ("height", 3.4e38, "height leaves"),
        ("height", 0.9, "height leaves"),
        ("normal", 3.0, "normals are not unit vectors"),
        ("normal", 3e38, "normals are not unit vectors"),
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


def test_the_tiles_of_every_shipped_preset_pass_the_checks(gl_ctx):
    """The checks refuse nothing a generator makes: a refused tile would be made again by the
    viewer, on every edit, with an error line each time."""
    from sand_editor.generator import generate
    from sand_editor.preset import Preset
    from sand_editor.resources import presets_dir

    paths = sorted(presets_dir().glob("*.json"))
    assert paths
    for path in paths:
        preset = Preset.load(path)
        for backend, ctx in (("gl", gl_ctx), ("reference", None)):
            shared = SharedTile(generate(preset, SIZE, backend=backend, ctx=ctx))
            try:
                back = read_shared(shared.name, SIZE, preset.generation)
            finally:
                shared.close()
            assert float(back.height.max()) <= MAX_HEIGHT, (path.stem, backend)


@pytest.fixture(scope="module")
def reference_tile() -> SandTextures:
    """A tile of the numpy reference: these tests need no GL."""
    from sand_editor.generator import generate
    from sand_editor.preset import Preset

    return generate(Preset(), SIZE, backend="reference")


def _tile_bytes(textures: SandTextures) -> bytes:
    return b"".join(np.ascontiguousarray(getattr(textures, name)).tobytes() for name, *_ in LAYOUT)


@contextmanager
def _segment(data: bytes = b""):
    """A segment of exactly ``data`` (any length, 0 too), by name; removed after."""
    name = f"sand_test_{uuid.uuid4().hex}"
    path = os.path.join(SEGMENT_FOLDER, name)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        os.write(fd, data)
        os.close(fd)
        yield name
    finally:
        os.unlink(path)


def _with_pixel(textures: SandTextures, field: str, where, value) -> SandTextures:
    """The tile with one pixel where ``where`` (a mask) holds set to ``value``."""
    arrays = {k: v.copy() for k, v in _arrays(textures).items()}
    index = tuple(np.argwhere(where)[len(np.argwhere(where)) // 2])
    arrays[field][index] = value
    return SandTextures(**arrays, generation=textures.generation)


@pytest.mark.parametrize(
    "field,where,value,reason",
    [
        ("grain_id", "gap", 12345, "gaps .* hold a grain id"),
        ("height", "gap", 0.5, "gaps .* hold a grain id or a height"),
        ("grain_id", "top", 0xFFFFFFFF, "glints are not those of its grain ids"),
        ("glint", "lower", 0.5, "glints are not those of its grain ids"),
        ("layer", "gap", 15, "layers leave -1"),
    ],
)
def test_grain_ids_and_layers_no_generator_makes_are_refused(
    reference_tile, field, where, value, reason
):
    layer = reference_tile.layer
    mask = {"gap": layer < 0, "top": layer == 0, "lower": layer > 0}[where]
    assert mask.any(), where
    shared = SharedTile(_with_pixel(reference_tile, field, mask, value))
    try:
        with pytest.raises(ValueError, match=reason):
            read_shared(shared.name, SIZE, None)  # no generation: up to MAX_LAYERS layers
    finally:
        shared.close()


@needs_dev_shm
def test_a_fifo_is_refused_unopened_and_left_in_place():
    """A FIFO would block whoever opens it for reading until a writer comes; an open of it in
    the viewer's grain thread would stall every new sand."""
    name = f"sand_test_{uuid.uuid4().hex}"
    path = os.path.join(SEGMENT_FOLDER, name)
    os.mkfifo(path, 0o600)
    outcome = []

    def read():
        try:
            read_shared(name, SIZE, None)
        except ValueError as exc:
            outcome.append(str(exc))

    try:
        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        reader.join(timeout=20)
        assert not reader.is_alive(), "read_shared blocked on the FIFO"
        assert outcome == [f"the shared tile {name!r} is a FIFO, not a segment"]
        assert os.path.exists(path), "the FIFO was removed"
    finally:
        os.unlink(path)


@needs_dev_shm
def test_links_and_folders_are_refused_and_what_a_link_names_is_untouched(reference_tile):
    data = _tile_bytes(reference_tile)
    with _segment(data) as target:
        link = f"sand_test_{uuid.uuid4().hex}"
        link_path = os.path.join(SEGMENT_FOLDER, link)
        os.symlink(os.path.join(SEGMENT_FOLDER, target), link_path)
        try:
            with pytest.raises(ValueError, match=f"{link}' is a link, not a segment"):
                read_shared(link, SIZE, None)
        finally:
            os.unlink(link_path)
        read_shared(target, SIZE, None)  # the segment itself is a tile
    folder = f"sand_test_{uuid.uuid4().hex}"
    os.mkdir(os.path.join(SEGMENT_FOLDER, folder))
    try:
        with pytest.raises(ValueError, match="is a folder, not a segment"):
            read_shared(folder, SIZE, None)
    finally:
        os.rmdir(os.path.join(SEGMENT_FOLDER, folder))
    for name in (".", "..", ".hidden"):
        with pytest.raises(ValueError, match="not starting with '.'"):
            read_shared(name, SIZE, None)


# The reader: read_shared many times, counting what each read gave; any other exception, or a
# signal, ends it with a status that is not 0.
# At least `reads` reads, and on until both a whole tile and a refusal were met or two minutes
# passed: on a loaded machine the writer thread may sleep through a few thousand reads.
_READER = """
import collections, json, sys, time
from sand_editor.generator.shared import read_shared
name, size, reads = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
seen = collections.Counter()
deadline = time.monotonic() + 120
while sum(seen.values()) < reads or (
    (seen["tile"] == 0 or len(seen) < 2) and time.monotonic() < deadline
):
    try:
        read_shared(name, size, None)
        seen["tile"] += 1
    except ValueError as exc:
        seen[str(exc)] += 1
print(json.dumps(seen))
"""
# What a read of a segment that another process truncates and rewrites may say, and only that.
_RACE_MESSAGES = re.compile(
    r"the shared tile '\w+' (has \d+ bytes, \d+ needed"
    r"|shrank while it was read: \d+ of \d+ bytes)"
    r"|the shared tile's .*"  # a read of a tile half rewritten: the values are checked
)


@needs_dev_shm
def test_a_segment_shrinking_while_it_is_read_gives_an_error_never_a_signal(reference_tile):
    """A thread here truncates the segment and writes it back again and again while another
    process reads it 3000 times or more. A reader copying a mapping died of SIGBUS (status -7)
    within a few dozen reads; reading the file, a shrink is a short read: one ``ValueError``."""
    data = _tile_bytes(reference_tile)
    reads = 3000
    with _segment(data) as name:
        stop = threading.Event()
        cycles = []

        def shrink_and_restore():
            fd = os.open(os.path.join(SEGMENT_FOLDER, name), os.O_RDWR)
            try:
                count = 0
                while not stop.is_set():
                    os.ftruncate(fd, len(data) // 3 * (count % 3))  # 0, a third, two thirds
                    os.ftruncate(fd, len(data))
                    os.pwrite(fd, data, 0)
                    count += 1
                cycles.append(count)
            finally:
                os.close(fd)

        writer = threading.Thread(target=shrink_and_restore, daemon=True)
        writer.start()
        try:
            result = subprocess.run(
                [sys.executable, "-c", _READER, name, str(SIZE), str(reads)],
                capture_output=True, text=True, timeout=300, cwd=REPO,
                env={**os.environ, "PYTHONPATH": str(REPO)},
            )  # fmt: skip
        finally:
            stop.set()
            writer.join(timeout=30)
        read_shared(name, SIZE, None)  # written back whole: a tile again
    assert result.returncode == 0, f"status {result.returncode}: {result.stderr[-2000:]}"
    seen = json.loads(result.stdout)
    assert sum(seen.values()) >= reads
    refusals = {message: n for message, n in seen.items() if message != "tile"}
    assert all(_RACE_MESSAGES.fullmatch(m) for m in refusals), refusals
    assert cycles and cycles[0] > 100, "the segment hardly changed while it was read"
    assert refusals, "no read met a shrunk segment"
    assert seen.get("tile", 0) > 0, "no read met the whole tile"


_FIELDS = [name for name, *_ in LAYOUT]
_values = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=32),
    st.integers(-(2**31), 2**32 - 1),
)


@needs_dev_shm
def test_a_normal_with_a_tiny_component_is_read_without_an_underflow_error(reference_tile):
    # Its square underflows float32; under np.errstate(all="raise") that was a FloatingPointError
    # (found by the fuzz test below), where the tile is a valid one.
    arrays = {k: v.copy() for k, v in _arrays(reference_tile).items()}
    arrays["normal"].reshape(-1, 3)[0] = (1e-30, 0.0, 1.0)
    data = b"".join(np.ascontiguousarray(arrays[k]).tobytes() for k in _FIELDS)
    with _segment(data) as name, np.errstate(all="raise"):
        tile = read_shared(name, SIZE, reference_tile.generation)
    assert tile.normal.reshape(-1, 3)[0, 0] == np.float32(1e-30)


@needs_dev_shm
@settings(
    max_examples=300, deadline=None, database=None,
    suppress_health_check=[HealthCheck.too_slow],
)  # fmt: skip
@given(
    patches=st.lists(
        st.tuples(st.sampled_from(_FIELDS), st.integers(0, SIZE * SIZE * 3 - 1), _values),
        max_size=4,
    ),
    raw=st.lists(
        st.tuples(st.integers(0, tile_bytes(SIZE) - 1), st.binary(min_size=1, max_size=16)),
        max_size=3,
    ),
    length=st.one_of(st.none(), st.integers(0, tile_bytes(SIZE) + 64)),
)
def test_any_segment_contents_give_a_checked_tile_or_one_value_error(
    reference_tile, patches, raw, length
):
    """A tile with values patched in (any float, any integer, in any field), bytes overwritten
    anywhere, and any length: what comes back holds only what a generator makes."""
    arrays = {k: v.copy() for k, v in _arrays(reference_tile).items()}
    for field, index, value in patches:
        flat = arrays[field].reshape(-1)
        with np.errstate(all="ignore"):
            flat[index % flat.size] = np.array(value).astype(flat.dtype)
    data = bytearray(b"".join(np.ascontiguousarray(arrays[k]).tobytes() for k in _FIELDS))
    for offset, chunk in raw:
        data[offset : offset + len(chunk)] = chunk
    if length is not None:  # cut short, or zeros after the tile
        data = data[:length].ljust(length, b"\0")
    with _segment(data) as name, np.errstate(all="raise"):  # no warning, no other error
        try:
            tile = read_shared(name, SIZE, reference_tile.generation)
        except ValueError as exc:
            assert "\n" not in str(exc)
            return
    for key in ("albedo", "normal", "height", "glint"):
        assert np.isfinite(getattr(tile, key)).all(), key
    assert 0 <= tile.height.min() and tile.height.max() <= MAX_HEIGHT
    assert 0 <= tile.albedo.min() and tile.albedo.max() <= 1
    assert 0 <= tile.glint.min() and tile.glint.max() <= 1
    assert -1 <= tile.layer.min() and tile.layer.max() < reference_tile.generation.layers
    assert (tile.grain_id[tile.layer < 0] == 0).all()
