"""The facet draw of glint_facets.glsl, run on its own: patches of the ground draw their own
Poisson counts of facets of random sizes, also where a patch is wider than the texture's tile
(far away, or a texture scale that makes the tile smaller than a facet). Drawn per tile, every
such patch would share one draw: the whole ground would sparkle or stay dark at once."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.colour import SHADER_DEFINES as COLOUR_DEFINES
from sand_editor.gl import (
    draw_fullscreen,
    drawing_into,
    release_program,
    shader_source,
    shader_text,
)
from sand_editor.render.material import (
    FACET_SIZE_RANGE,
    FACETS_PER_LARGEST,
    LIGHT_ANGULAR_RADIUS,
)

pytestmark = pytest.mark.gl

CELLS = 64  # patches along each side of the image, one pixel each
TEXTURE_SIZE = 256.0  # finest-level texels per tile
LAMBDA = 1.0  # mirroring facets' area a patch holds on average, in largest facets'
# Facets by number per largest facet's area, and the mean square of one's area (1/r² uniform in
# [1, R²] by number: glint_facets.glsl).
R2 = FACET_SIZE_RANGE**2
PER_LARGEST = FACETS_PER_LARGEST
AREA_SQUARED = 1.0 / R2

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


def _counts(ctx, patch_texels: float, mean_area: float = LAMBDA) -> np.ndarray:
    # Hand-assembled, so it adds the facts sand_editor/gl.py gives every program itself.
    shared = "".join(f"#define {key} {value}\n" for key, value in COLOUR_DEFINES.items())
    defines = shared + (
        f"#define CELLS {CELLS}\n#define TEXTURE_SIZE {TEXTURE_SIZE}\n"
        f"#define LAMBDA {mean_area!r}\n"
        f"#define FACET_SIZE_RANGE {FACET_SIZE_RANGE!r}\n"
        f"#define FACETS_PER_LARGEST {FACETS_PER_LARGEST!r}\n"
        f"#define LIGHT_ANGULAR_RADIUS {LIGHT_ANGULAR_RADIUS!r}\n"
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
    areas = _counts(gl_clean, TEXTURE_SIZE * tiles_per_patch)
    assert areas.min() >= 0 and np.isfinite(areas).all()
    # A Poisson count of facets of random sizes (4096 patches): the area's mean is LAMBDA (within
    # 10 %), its variance the compound Poisson's, LAMBDA·(facets per largest)·E[area²] (15 %).
    assert areas.mean() == pytest.approx(LAMBDA, rel=0.1)
    assert areas.var() == pytest.approx(LAMBDA * PER_LARGEST * AREA_SQUARED, rel=0.15)
    # No facet at all: e^(−mean count).
    assert (areas == 0).mean() == pytest.approx(np.exp(-LAMBDA * PER_LARGEST), abs=0.01)
    # Patches one tile apart (or less, when a patch is a tile or more) are not copies: two
    # independent draws agree only when both hold no facet.
    step = max(int(round(1.0 / tiles_per_patch)), 1)
    same = (areas[:, step:] == areas[:, :-step]).mean()
    assert same < 0.01 + 2.0 * np.exp(-2.0 * LAMBDA * PER_LARGEST)


@pytest.mark.parametrize("mean_area", [30.0, 1000.0, 1.0e6])
def test_many_facets_in_a_pixel_vary_as_many_facets_do(gl_clean, mean_area):
    # Past 16 mirroring facets a patch places 16 stand-ins; a pixel of thousands or millions of
    # facets must still vary as that many do (relative spread 1/√count), not as sixteen.
    areas = _counts(gl_clean, TEXTURE_SIZE / 4.0, mean_area)
    assert np.isfinite(areas).all() and areas.min() >= 0
    assert areas.mean() == pytest.approx(mean_area, rel=0.02)
    assert areas.var() == pytest.approx(mean_area * PER_LARGEST * AREA_SQUARED, rel=0.15)
