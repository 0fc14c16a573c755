"""The GL generator's own behaviour: progressive generation, band rendering, GL state."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.generator import generate, generate_progressive, gl_generator

pytestmark = pytest.mark.gl

FIELDS = ("albedo", "normal", "height", "glint", "layer", "grain_id", "average_albedo")


def assert_identical(a, b) -> None:
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert x.tobytes() == y.tobytes(), name


@pytest.mark.parametrize(("size", "band_rows"), [(256, 100), (200, 64), (256, 256)])
def test_progressive_steps_and_result(sand, gl_ctx, size, band_rows, strict_numpy):
    preset = sand.preset(seed=7)
    steps = list(generate_progressive(preset, size, band_rows=band_rows))
    first, *middle, last = steps
    assert first is not None and first.size == 128
    assert_identical(first, sand.generate(preset, 128, "gl"))
    bands = -(-size // band_rows)
    assert middle == [None] * (bands - 1)
    assert last.size == size
    assert_identical(last, sand.generate(preset, size, "gl"))


def test_progressive_small_size_has_no_preview(sand, gl_ctx):
    steps = list(generate_progressive(sand.preset(), 128))
    assert len(steps) == 1 and steps[0].size == 128
    steps = list(generate_progressive(sand.preset(), 100, band_rows=30))
    assert steps[:-1] == [None] * 3 and steps[-1].size == 100


def test_progressive_dropped_early_releases_its_textures(sand, gl_ctx):
    steps = generate_progressive(sand.preset(), 256, band_rows=64)
    assert next(steps).size == 128
    assert next(steps) is None
    steps.close()
    # The context still works afterwards.
    preset = sand.preset(seed=3)
    np.testing.assert_array_equal(
        sand.generate_fresh(preset, 64, "gl").layer, sand.generate(preset, 64, "reference").layer
    )


def test_band_rendering_equals_one_shot(sand, gl_ctx, strict_numpy):
    preset = sand.preset(seed=11, layers=12)
    nc = sand.constants(preset)
    generator = gl_generator(gl_ctx)
    size = 256
    one_shot = generator.render(nc, size)
    banded = generator.render(nc, size, rows=(0, 100))
    for start in (100, 200):
        generator.render(nc, size, banded, rows=(start, min(size, start + 100)))
    try:
        assert_identical(banded.read(nc), one_shot.read(nc))
    finally:
        one_shot.release()
        banded.release()


def test_render_rejects_a_target_of_another_size(sand, gl_ctx):
    generator = gl_generator(gl_ctx)
    target = generator.allocate(64)
    try:
        with pytest.raises(ValueError, match="64"):
            generator.render(sand.constants(sand.preset()), 128, target)
    finally:
        target.release()


def test_generate_leaves_no_gl_error(sand, gl_ctx):
    generate(sand.preset(), 64)
    generate(sand.preset(), 64)
    assert gl_ctx.error == "GL_NO_ERROR"
