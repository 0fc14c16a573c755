"""A finished tile of grains handed to another process through shared memory, so that the VR
viewer shows the grains the editor made instead of making them again.

The maker writes the tile's arrays one after the other into a named segment
(``SharedTile.create``) and tells the other process its name; the reader copies them out
(``read_shared``), checking that they are what a generator makes (finite, in range, unit
normals), and closes its view at once. The maker unlinks the segment once the reader is done.
A segment's name comes over the editor ↔ viewer link, so every fault is a ``ValueError``
naming what is wrong.
"""

from __future__ import annotations

import re
import sys
from multiprocessing import resource_tracker
from multiprocessing.shared_memory import SharedMemory

import numpy as np

from sand_editor.generator._textures import SandTextures

# (field, dtype, channels), in the order they lie in the segment.
LAYOUT = (
    ("albedo", np.float32, 3),
    ("normal", np.float32, 3),
    ("height", np.float32, 1),
    ("glint", np.float32, 1),
    ("grain_id", np.uint32, 1),
    ("layer", np.int8, 1),
)
SIZES = (64, 128, 256, 512, 1024, 2048)
# Names Python makes ("psm_" and hex) and others of the kind; never a path.
NAME_PATTERN = re.compile(r"[A-Za-z0-9_.-]{1,64}")
UNIT_TOLERANCE = 1e-3  # the generator's normals are unit to float precision
_MADE_HERE: set[str] = set()  # names of the segments this process made and has not unlinked


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
        _MADE_HERE.add(self.name)
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
        _MADE_HERE.discard(memory.name)


def _attach(name: str) -> SharedMemory:
    """Open an existing segment without this process claiming it.

    Python before 3.13 registers every opened segment with the process's resource tracker,
    which unlinks it when the process exits (cpython#82300) and warns of a leak: the maker's
    segment would vanish with its reader. 3.13 has ``track=False`` for exactly this. A segment
    this process made stays registered: its maker unregisters it when unlinking it.
    """
    if sys.version_info >= (3, 13):
        return SharedMemory(name=name, track=False)
    memory = SharedMemory(name=name)
    if memory.name not in _MADE_HERE:
        resource_tracker.unregister(memory._name, "shared_memory")  # noqa: SLF001 - see above
    return memory


def read_shared(name: str, size: int, generation) -> SandTextures:
    """The tile in segment ``name`` (``size``²), copied out and checked, carrying
    ``generation`` (whoever made it says which).

    Raises
    ------
    ValueError
        Naming what is wrong: the name, the size, a missing or short segment, or values no
        generator makes.
    """
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"a shared tile's name is 1-64 letters, digits, '_', '.' or '-': {name!r}")
    if size not in SIZES:
        raise ValueError(f"a shared tile is {', '.join(map(str, SIZES))} pixels wide, not {size}")
    try:
        memory = _attach(name)
    except FileNotFoundError:
        raise ValueError(f"no shared tile {name!r} (it was removed, or never made)") from None
    except OSError as exc:
        raise ValueError(f"cannot open the shared tile {name!r}: {exc.strerror}") from None
    try:
        needed = tile_bytes(size)
        if memory.size < needed:
            raise ValueError(f"the shared tile {name!r} has {memory.size} bytes, {needed} needed")
        arrays = {key: view.copy() for key, view in _views(memory.buf, size).items()}
    finally:
        memory.close()
    _check(arrays, generation)
    return SandTextures(**arrays, generation=generation)


def _check(arrays: dict[str, np.ndarray], generation) -> None:
    for key in ("albedo", "normal", "height", "glint"):
        if not np.isfinite(arrays[key]).all():
            raise ValueError(f"the shared tile's {key} holds values that are not finite")
    for key, low, high in (("albedo", 0.0, 1.0), ("glint", 0.0, 1.0), ("height", 0.0, np.inf)):
        values = arrays[key]
        if values.min() < low or values.max() > high:
            raise ValueError(f"the shared tile's {key} leaves [{low:g}, {high:g}]")
    length = np.linalg.norm(arrays["normal"], axis=-1)
    if np.abs(length - 1.0).max() > UNIT_TOLERANCE:
        raise ValueError("the shared tile's normals are not unit vectors")
    layers = getattr(generation, "layers", None)
    layer = arrays["layer"]
    if layers is not None and (layer.min() < -1 or layer.max() >= layers):
        raise ValueError(f"the shared tile's layers leave -1 (a gap) to {layers - 1}")
