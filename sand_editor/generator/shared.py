"""A finished tile of grains handed to another process through shared memory, so that the VR
viewer shows the grains the editor made instead of making them again.

The maker writes the tile's arrays one after the other into a named segment
(``SharedTile.create``) and tells the other process its name; the reader copies them out
(``read_shared``), checking that they are what a generator makes (finite, in range, unit
normals), and closes the segment at once. The maker unlinks the segment once the reader is done.
A segment's name comes over the editor ↔ viewer link, so every fault is a ``ValueError``
naming what is wrong.

The reader never maps a segment: another process can truncate it while it is read, and a read
of a mapping past the new end is a SIGBUS that kills the reader. It reads the segment's file
(Linux keeps segments as files in ``/dev/shm``) with ``os.preadv`` into arrays of its own, where
a shrink is a short read, and opens only a regular file there: a FIFO would block the open.
"""

from __future__ import annotations

import errno
import os
import re
import stat
from multiprocessing.shared_memory import SharedMemory

import numpy as np

from sand_editor.generator._textures import SandTextures
from sand_editor.generator.noise import MAX_LAYERS, PROFILE_OFFSET, PROFILE_SCALE, UNIT_8
from sand_editor.generator.sizes import SHARED_SIZES

# (field, dtype, channels), in the order they lie in the segment.
LAYOUT = (
    ("albedo", np.float32, 3),
    ("normal", np.float32, 3),
    ("height", np.float32, 1),
    ("glint", np.float32, 1),
    ("grain_id", np.uint32, 1),
    ("layer", np.int8, 1),
)
SIZES = SHARED_SIZES
# Names Python makes ("psm_" and hex) and others of the kind; never a path, nor "." or "..".
NAME_PATTERN = re.compile(r"(?!\.)[A-Za-z0-9_.-]{1,64}")
NAME_RULE = "1-64 letters, digits, '_', '.' or '-', not starting with '.'"
SEGMENT_FOLDER = "/dev/shm"  # where glibc's and musl's shm_open keep segments
UNIT_TOLERANCE = 1e-3  # the generator's normals are unit to float precision
# A grain's height is its profile 0.08 + 0.8·(√F2 − √F1) with both distances clamped at 1
# (noise.py), so at most 0.88, and 0 in gaps; the margin is float32 rounding. Anything above is
# no sand, however finite: the relief and the glints would take it as a slope.
MAX_HEIGHT = PROFILE_OFFSET + PROFILE_SCALE + 1e-4


def tile_bytes(size: int) -> int:
    """Bytes a tile of ``size``² takes in a segment."""
    return sum(size * size * channels * np.dtype(dtype).itemsize for _, dtype, channels in LAYOUT)


def _views(buffer, size: int) -> dict[str, np.ndarray]:
    views, offset = {}, 0
    for name, dtype, channels in LAYOUT:
        shape = (size, size, channels) if channels > 1 else (size, size)
        count = size * size * channels
        views[name] = np.frombuffer(buffer, dtype, count, offset).reshape(shape)
        offset += count * np.dtype(dtype).itemsize
    return views


def _write(buffer, textures: SandTextures) -> None:
    """The tile's arrays into ``buffer``; the views into it end with the call, so that the
    segment can be closed after."""
    for name, view in _views(buffer, textures.size).items():
        view[...] = getattr(textures, name)


class SharedTile:
    """A tile written into a new segment, which this object owns: ``close()`` unlinks it."""

    def __init__(self, textures: SandTextures) -> None:
        self.size = textures.size
        if self.size not in SIZES:
            raise ValueError(f"tiles of {self.size}² are not shared; sizes: {SIZES}")
        self._memory = SharedMemory(create=True, size=tile_bytes(self.size))
        self.name = self._memory.name
        try:
            _write(self._memory.buf, textures)
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Unmap and unlink the segment (a reader that already copied it is unaffected)."""
        memory, self._memory = self._memory, None
        if memory is None:
            return
        memory.close()
        try:
            memory.unlink()
        except FileNotFoundError:
            pass


def read_shared(name: str, size: int, generation) -> SandTextures:
    """The tile in segment ``name`` (``size``²), copied out and checked, carrying
    ``generation`` (whoever made it says which).

    Raises
    ------
    ValueError
        Naming what is wrong, in one line: the name, the size, a missing, short or shrinking
        segment, one that is no regular file, or values no generator makes.
    """
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"a shared tile's name is {NAME_RULE}: {name!r}")
    if size not in SIZES:
        raise ValueError(f"a shared tile is {', '.join(map(str, SIZES))} pixels wide, not {size}")
    needed = tile_bytes(size)
    fd, length = _open_segment(name)
    try:
        if length < needed:
            raise ValueError(f"the shared tile {name!r} has {length} bytes, {needed} needed")
        buffer = np.empty(needed, np.uint8)
        _read_into(fd, buffer, name)
    finally:
        os.close(fd)
    # Views into the one buffer read: a copy of each array would cost as much again.
    arrays = _views(buffer, size)
    _check(arrays, generation)
    return SandTextures(**arrays, generation=generation)


def _open_segment(name: str) -> tuple[int, int]:
    """A read-only descriptor of segment ``name`` and its length; only a regular file is
    opened (looked at first, then opened without following a link or waiting)."""
    path = os.path.join(SEGMENT_FOLDER, name)
    try:
        found = os.lstat(path)
        if not stat.S_ISREG(found.st_mode):
            raise ValueError(f"the shared tile {name!r} is {_kind(found.st_mode)}, not a segment")
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise ValueError(f"no shared tile {name!r} (it was removed, or never made)") from None
    except OSError as exc:
        raise ValueError(f"cannot open the shared tile {name!r}: {_reason(exc)}") from None
    opened = os.fstat(fd)
    if (opened.st_dev, opened.st_ino) != (found.st_dev, found.st_ino):
        os.close(fd)  # replaced between the look and the open: by whom, and with what?
        raise ValueError(f"the shared tile {name!r} was replaced while it was opened")
    return fd, opened.st_size


def _read_into(fd: int, buffer: np.ndarray, name: str) -> None:
    """Fill ``buffer`` from the start of the segment; a segment that ends first (it shrank
    after its length was taken) is a ``ValueError``, not a signal."""
    view = memoryview(buffer)
    done = 0
    while done < len(view):
        try:
            got = os.preadv(fd, [view[done:]], done)
        except OSError as exc:
            raise ValueError(f"cannot read the shared tile {name!r}: {_reason(exc)}") from None
        if got == 0:
            raise ValueError(
                f"the shared tile {name!r} shrank while it was read: {done} of {len(view)} bytes"
            )
        done += got


_KINDS = ((stat.S_ISLNK, "a link"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISDIR, "a folder"))


def _kind(mode: int) -> str:
    """What a file that is no segment is, for the message."""
    return next((kind for test, kind in _KINDS if test(mode)), "a device or socket")


def _reason(exc: OSError) -> str:
    if exc.errno == errno.ELOOP:  # O_NOFOLLOW met a link made after the look
        return "it is a link"
    return exc.strerror or str(exc)


def _check(arrays: dict[str, np.ndarray], generation) -> None:
    for key in ("albedo", "normal", "height", "glint"):
        if not np.isfinite(arrays[key]).all():
            raise ValueError(f"the shared tile's {key} holds values that are not finite")
    bounds = (("albedo", 0.0, 1.0), ("glint", 0.0, 1.0), ("height", 0.0, MAX_HEIGHT))
    for key, low, high in bounds:
        values = arrays[key]
        if values.min() < low or values.max() > high:
            raise ValueError(f"the shared tile's {key} leaves [{low:g}, {high:g}]")
    normal = arrays["normal"]
    # Components first: the length of a huge (finite) one would overflow, a warning or, under
    # np.seterr(all="raise"), an error that is no ValueError.
    if np.abs(normal).max() > 1.0 + UNIT_TOLERANCE:
        raise ValueError("the shared tile's normals are not unit vectors")
    with np.errstate(under="ignore"):  # a tiny component squares to zero, which is harmless
        length = np.linalg.norm(normal, axis=-1)
    if np.abs(length - 1.0).max() > UNIT_TOLERANCE:
        raise ValueError("the shared tile's normals are not unit vectors")
    layers = getattr(generation, "layers", None) or MAX_LAYERS
    layer = arrays["layer"]
    if layer.min() < -1 or layer.max() >= layers:
        raise ValueError(f"the shared tile's layers leave -1 (a gap) to {layers - 1}")
    # A grain id is the owning grain's 32-bit word (noise.py): 0 in a gap, where nothing owns
    # the pixel; its top byte is the glint of a top-layer grain.
    gap = layer < 0
    if (arrays["grain_id"][gap] != 0).any() or (arrays["height"][gap] != 0).any():
        raise ValueError("the shared tile's gaps (layer -1) hold a grain id or a height")
    top = layer == 0
    glint = (arrays["grain_id"][top] >> np.uint32(24)).astype(np.float32) * np.float32(UNIT_8)
    if not np.array_equal(glint, arrays["glint"][top]) or (arrays["glint"][~top] != 0).any():
        raise ValueError("the shared tile's glints are not those of its grain ids")
