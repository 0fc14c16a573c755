"""The facet draw of glint_facets.glsl, run on its own: patches of the ground draw their own
Poisson counts, also where a patch is wider than the texture's tile (far away, or a texture
scale that makes the tile smaller than a facet). Drawn per tile, every such patch would share
one draw: the whole ground would sparkle or stay dark at once."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.gl import (
    draw_fullscreen,
    drawing_into,
    release_program,
    shader_source,
    shader_text,
)

pytestmark = pytest.mark.gl

CELLS = 64  # patches along each side of the image, one pixel each
TEXTURE_SIZE = 256.0  # finest-level texels per tile
LAMBDA = 4.0  # mirroring facets a patch holds on average

_MAIN = """
uniform float u_patch_texels;  // edge of a patch, finest-level texels
out vec4 colour;
void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy) - ivec2(CELLS / 2);
    // A footprint exactly one patch wide, centred on the patch: it holds all of its facets.
    float size_tiles = u_patch_texels / TEXTURE_SIZE;
    vec2 tc = (vec2(cell) + 0.5) * size_tiles;
    Patches p = footprint_patches(tc, vec2(size_tiles, 0.0), vec2(0.0, size_tiles),
                                  TEXTURE_SIZE, 1.0);
    float count = facets_in_pixel(p, cell, LAMBDA, vec2(0.1, -0.05), 0u);
    colour = vec4(count, p.size, float(p.first.x - cell.x), float(p.first.y - cell.y));
}
"""


def _counts(ctx, patch_texels: float) -> np.ndarray:
    defines = (
        f"#define CELLS {CELLS}\n#define TEXTURE_SIZE {TEXTURE_SIZE}\n#define LAMBDA {LAMBDA}\n"
    )
    fragment = (
        "#version 330 core\n"
        + defines
        + shader_source("common.glsl")
        + shader_text("glint_facets.glsl")
        + _MAIN
    )
    program = ctx.program(vertex_shader=shader_text("fullscreen.vert"), fragment_shader=fragment)
    program["u_patch_texels"].value = patch_texels
    target = ctx.texture((CELLS, CELLS), 4, dtype="f4")
    framebuffer = ctx.framebuffer([target])
    try:
        with drawing_into(ctx, framebuffer):
            ctx.viewport = (0, 0, CELLS, CELLS)
            draw_fullscreen(ctx, program)
        out = np.frombuffer(target.read(), dtype=np.float32).reshape(CELLS, CELLS, 4)
    finally:
        framebuffer.release()
        target.release()
        release_program(program)
    # The footprint chose the patch level asked for and lies on its own cell.
    assert np.all(out[..., 1] == patch_texels)
    assert np.all(out[..., 2:] == 0.0)
    return out[..., 0]


@pytest.mark.parametrize("tiles_per_patch", [1 / 16, 1.0, 4.0, 64.0])
def test_each_patch_of_the_ground_draws_its_own_poisson_count(gl_clean, tiles_per_patch):
    counts = _counts(gl_clean, TEXTURE_SIZE * tiles_per_patch)
    assert np.all(counts == np.round(counts)) and counts.min() >= 0
    # Poisson: mean and variance both LAMBDA (4096 patches: within 10 %).
    assert counts.mean() == pytest.approx(LAMBDA, rel=0.1)
    assert counts.var() == pytest.approx(LAMBDA, rel=0.15)
    # Patches one tile apart (or less, when a patch is a tile or more) are not copies.
    step = max(int(round(1.0 / tiles_per_patch)), 1)
    same = (counts[:, step:] == counts[:, :-step]).mean()
    poisson = np.exp(-2 * LAMBDA) * np.i0(2 * LAMBDA)  # chance two draws agree
    assert same < 1.5 * poisson
