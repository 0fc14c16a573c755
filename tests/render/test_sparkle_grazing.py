"""Sparkles at grazing views towards a low sun, where footprints are long and each holds many
mirroring facets: they must stay points, never flat blocks of one patch's draw."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.render.request import FrameRequest
from tests.render.conftest import renderer_with_material

pytestmark = pytest.mark.gl

SPARKLE_LEVEL = 16  # 8-bit value above which a pixel of the glints view holds a sparkle


def _longest_flat_run(row: np.ndarray) -> int:
    """Longest horizontal run of equal, lit pixels in one row of RGB values."""
    lit = row.sum(axis=-1) > 3 * SPARKLE_LEVEL
    same = np.all(row[1:] == row[:-1], axis=-1) & lit[1:] & lit[:-1]
    longest = run = 0
    for flag in same:
        run = run + 1 if flag else 0
        longest = max(longest, run)
    return longest + 1 if longest else int(lit.any())


def test_grazing_sparkles_toward_the_low_sun_are_points_not_blocks(gl_ctx):
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.exposure import light_exposure
    from sand_editor.render.sky import parse_time, sky_at

    with renderer_with_material(gl_ctx, texture_size=1024) as renderer:
        terrain = renderer.terrain
        camera = camera_at_distance(
            0.3, 35.0, 480 / 270, ground_height=lambda x, z: float(terrain.height(x, z))
        )
        sky = sky_at(parse_time("16:30"))
        # The light's exposure, not one metered on a frame of glints alone (which would
        # saturate every sparkle to white and hide how each is drawn).
        image = renderer.render_to_array(
            480, 270, FrameRequest(camera, sky, "glints", exposure=light_exposure(sky))
        )
        hdr = np.frombuffer(renderer.post.scene_texture.read(), dtype=np.float16)
    assert np.isfinite(hdr).all(), "no NaN or inf in the HDR frame, grazing glints included"
    band = image[:70].astype(np.int32)  # the far sand, seen at a grazing angle
    lit = band.sum(axis=-1) > 3 * SPARKLE_LEVEL
    # Physically bounded: every clear grain's facets of paper-default, a few percent of pixels.
    assert lit.mean() > 0.02, "the far band should glitter towards the sun"
    runs = [_longest_flat_run(row) for row in band]
    # A sparkle is a point: a few neighbours may hold one facet each and match; a patch drawn
    # once for all its pixels shows as a run of identical values many pixels long.
    assert max(runs) <= 6, f"flat runs of {max(runs)} identical lit pixels"
    same_as_right = np.all(band[:, 1:] == band[:, :-1], axis=-1) & lit[:, 1:] & lit[:, :-1]
    assert same_as_right.sum() / lit.sum() < 0.15
