"""Sand grain textures from a preset: ``generate(preset, size, backend)``.

``backend="gl"`` renders in GLSL through moderngl (a headless EGL context when none is given);
``backend="reference"`` evaluates the same maths in float64 numpy, the accuracy oracle.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from sand_editor.generator._textures import SandTextures
from sand_editor.generator.noise import NoiseConstants
from sand_editor.generator.sizes import MAX_SIZE, MIN_SIZE, check_size

__all__ = [
    "BACKENDS",
    "GpuSandTextures",
    "MAX_SIZE",
    "MIN_SIZE",
    "SandTextures",
    "check_size",
    "generate",
    "generate_progressive",
    "gl_generator",
]

BACKENDS = ("gl", "reference")


def _generation(preset_or_generation):
    return getattr(preset_or_generation, "generation", preset_or_generation)


def gl_generator(ctx=None):
    """The GL generator of a context (the headless one by default), compiled once per context."""
    from sand_editor.generator._gl import GLGenerator
    from sand_editor.gl import standalone_context

    ctx = ctx if ctx is not None else standalone_context()
    cache = ctx.extra if isinstance(ctx.extra, dict) else {}
    ctx.extra = cache
    if "sand_generator" not in cache:
        cache["sand_generator"] = GLGenerator(ctx)
    return cache["sand_generator"]


def generate(preset, size: int, backend: str = "gl", ctx=None) -> SandTextures:
    """Generate the grain textures of a preset (or its ``generation`` section) at size×size."""
    size = check_size(size)
    generation = _generation(preset)
    constants = NoiseConstants.from_generation(generation)
    if backend == "gl":
        gpu = gl_generator(ctx).render(constants, size)
        try:
            return gpu.read(constants, generation)
        finally:
            gpu.release()
    if backend == "reference":
        return _generate_reference(constants, size, generation)
    raise ValueError(f"unknown backend {backend!r}; allowed: {', '.join(BACKENDS)}")


def _generate_reference(nc: NoiseConstants, size: int, generation) -> SandTextures:
    from sand_editor.generator.reference import evaluate

    ys, xs = np.divmod(np.arange(size * size), size)
    values = evaluate(nc, size, xs, ys)
    return SandTextures(
        albedo=values["albedo"].reshape(size, size, 3).astype(np.float32),
        normal=values["normal"].reshape(size, size, 3).astype(np.float32),
        height=values["height"].reshape(size, size).astype(np.float32),
        glint=values["glint"].reshape(size, size).astype(np.float32),
        layer=values["layer"].reshape(size, size),
        grain_id=values["grain"].reshape(size, size),
        generation=generation,
    )


def generate_progressive(
    preset, size: int, first_size: int = 128, band_rows: int = 256, ctx=None
) -> Iterator[SandTextures | None]:
    """Generate a quick low-resolution tile first, then the full one in short GPU steps.

    Yields the ``first_size`` textures, then ``None`` after each band of ``band_rows`` rows of the
    full texture (a chance for an event loop to run), and finally the full textures. A caller
    that drops the iterator early cancels the rest of the work.
    """
    size = check_size(size)
    first_size = check_size(min(first_size, size))
    generation = _generation(preset)
    constants = NoiseConstants.from_generation(generation)
    generator = gl_generator(ctx)
    if first_size < size:
        yield generate(preset, first_size, ctx=generator.ctx)
    target = generator.allocate(size)
    try:
        for _start, stop in generator.render_in_bands(constants, target, band_rows):
            if stop < size:
                generator.ctx.finish()
                yield None
        yield target.read(constants, generation)
    finally:
        target.release()


def __getattr__(name: str):
    # The GL side is imported only when asked for: the generator's maths import no OpenGL.
    if name == "GpuSandTextures":
        from sand_editor.generator._gl import GpuSandTextures

        return GpuSandTextures
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
