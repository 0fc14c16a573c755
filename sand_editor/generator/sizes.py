"""The grain tile's sizes (edge in texels), for every place that offers or checks one: the
generator's limits, the editor's preview and bake menus, the VR viewer's ``--texture-size``, the
tiles the editor shares with the viewer, the command line's defaults. Standard library only."""

from __future__ import annotations

MIN_SIZE = 64
MAX_SIZE = 4096
SIZE_RANGE = f"{MIN_SIZE}-{MAX_SIZE}"  # as the command line's help says it


def powers_of_two(low: int, high: int) -> tuple[int, ...]:
    """The powers of two from ``low`` to ``high``, both included (both powers of two)."""
    sizes = []
    size = low
    while size <= high:
        sizes.append(size)
        size *= 2
    return tuple(sizes)


# The editor's live preview: the viewer started from the editor is given the same tile.
PREVIEW_SIZES = powers_of_two(256, 1024)
DEFAULT_PREVIEW_SIZE = 512
# The VR viewer's own tile (``sand-editor vr --texture-size``) and the renderer's default.
VR_SIZES = powers_of_two(256, 2048)
DEFAULT_RENDER_SIZE = 1024
# Tiles the editor may share with the viewer through shared memory.
SHARED_SIZES = powers_of_two(MIN_SIZE, VR_SIZES[-1])
# Texture sets written to disk: the editor's bake menu, ``bake --size`` and ``export --size``.
BAKE_SIZES = powers_of_two(512, MAX_SIZE)
DEFAULT_BAKE_SIZE = 2048
DEFAULT_EXPORT_SIZE = 1024


def check_size(size) -> int:
    """``size`` as an int, or ``ValueError`` naming the range allowed."""
    if isinstance(size, bool) or not hasattr(size, "__index__"):
        raise ValueError(
            f"texture size must be an integer from {MIN_SIZE} to {MAX_SIZE}, got {size!r}"
        )
    size = size.__index__()
    if not MIN_SIZE <= size <= MAX_SIZE:
        raise ValueError(f"texture size {size} is out of range; allowed {MIN_SIZE} to {MAX_SIZE}")
    return size
