"""The editor's finished tiles, handed to the VR viewer through shared memory: an edit of the
grains is made once, by the editor, and the viewer shows that tile instead of making it again.

A preset whose grains the viewer does not have yet waits (at most ``HOLD_LIMIT_S``) for the
editor's tile of its generation, then goes with the tile's segment; the segment is unlinked once
the viewer shows that preset or a later one, or the viewer ends.
"""

from __future__ import annotations

from sand_editor.generator.shared import SIZES, SharedTile
from sand_editor.preset import Preset

HOLD_LIMIT_S = 20.0  # a tile that takes longer: the viewer makes the grains itself
MAX_SEGMENTS = 4  # tiles handed over and not yet shown; the oldest go first


class SharedTiles:
    """Tiles of ``regenerator`` (the editor's generator of the preview and the 3D view) for the
    viewer, while ``size`` is set: the viewer's grains are that size, the editor's tiles too."""

    def __init__(self, regenerator) -> None:
        self._regenerator = regenerator
        self._segments: dict[int, SharedTile] = {}
        self.size: int | None = None

    def start(self, share: bool) -> int | None:
        """A new viewer: drop what the last one was given; share the tiles of the editor's size
        (returned, for the viewer's command line) when ``share``, else none."""
        self.clear()
        size = self._regenerator.size
        self.size = size if share and size in SIZES else None
        return self.size

    def fields(self, preset: Preset, sent: Preset | None, seq: int, held_s: float) -> dict | None:
        """What a preset message numbered ``seq`` carries besides the preset: ``{"grains":
        ...}`` with the editor's tile, ``{}`` when the viewer has the grains or must make them,
        None while the tile is on its way (ask again; ``held_s`` is how long it has waited)."""
        generation = preset.generation
        regenerator = self._regenerator
        if self.size is None or (sent is not None and sent.generation == generation):
            return {}
        if regenerator.size != self.size or regenerator.failed_generation == generation:
            return {}
        textures = regenerator.full_tile(generation, self.size)
        if textures is None:
            return None if held_s < HOLD_LIMIT_S else {}
        tile = SharedTile(textures)
        self._segments[seq] = tile
        while len(self._segments) > MAX_SEGMENTS:
            self._segments.pop(min(self._segments)).close()
        return {"grains": {"shm": tile.name, "size": tile.size}}

    def shown(self, seq: int) -> None:
        """The viewer shows preset ``seq``: it has read every tile sent up to it."""
        for sent in [s for s in self._segments if s <= seq]:
            self._segments.pop(sent).close()

    def clear(self) -> None:
        while self._segments:
            self._segments.popitem()[1].close()

    @property
    def segments(self) -> int:
        """Tiles handed over and not yet released."""
        return len(self._segments)
