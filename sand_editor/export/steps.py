"""Long jobs in short steps, so that a caller (the editor's dialog, the command line's progress
bar) can show progress and stop between them."""

from __future__ import annotations

from sand_editor.generator import generate, generate_progressive
from sand_editor.preset import Preset

BAND_ROWS = 128  # rows per generation step, so a caller can cancel between them


def generation_steps(preset: Preset, size: int, ctx=None, share: float = 0.6, backend="gl"):
    """Generate a tile in bands: yields (fraction done, what), returns the textures (as the
    generator's ``StopIteration.value``). The GL generator's bands let a caller stop between
    them; the numpy backends make the tile in one step."""
    if backend != "gl":
        yield 0.0, "Generating the grains"
        return generate(preset, size, backend=backend)
    bands = max(1, -(-size // BAND_ROWS))
    done = 0
    textures = None
    progressive = generate_progressive(preset, size, first_size=size, band_rows=BAND_ROWS, ctx=ctx)
    try:
        for result in progressive:
            done += 1
            yield share * min(done, bands) / bands, "Generating the grains"
            textures = result
    finally:
        progressive.close()
    return textures


class Steps:
    """A long job in short steps: iterate to run it; each step yields (fraction done, what
    comes next). Stopping early (``close()``, or dropping it) writes nothing: the files are
    written, all at once, only in the last step. ``record`` holds the job's record once done."""

    def __init__(self, steps) -> None:
        self.record: dict | None = None
        self._steps = steps

    def __iter__(self):
        return self

    def __next__(self) -> tuple[float, str]:
        return next(self._steps)

    def close(self) -> None:
        self._steps.close()
