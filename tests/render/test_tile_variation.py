"""The grain tile laid without a repeat (shaders/tile_variation.glsl): no grid, the tile's own
statistics, and every copy shaded in its own axes."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.bench import repetition
from sand_editor.bench.probe import MaterialProbe
from sand_editor.colour import luminance
from sand_editor.generator import SandTextures
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from sand_editor.resources import bundled_preset

NO_DETAIL = {"shading.detail_strength": 0.0}


@pytest.fixture(scope="module")
def probe(gl_ctx):
    material = SandMaterial(gl_ctx, 512)  # the grid shows less in coarser tiles' sparkles
    probe = MaterialProbe(material, *repetition.SIZE)
    probe.ripples = False
    yield probe
    probe.release()
    material.release()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-default", "red-desert"])
def test_the_tile_shows_no_grid_where_it_repeated_as_one(probe, gl_clean, name):
    preset = Preset.load(bundled_preset(name)).replace(**NO_DETAIL)
    probe.material.update(preset)
    for row in repetition.measure(probe, preset, [(1.0, 90.0)]):  # full and close frames
        # The measure sees the grid of the tile as it repeats ...
        assert row["repeating"] > 0.1, row
        # ... and none once it is varied.
        assert row["varied"] < repetition.TARGET, row


def test_copies_keep_the_tiles_mean(probe, gl_clean):
    preset = Preset.load(bundled_preset("paper-default")).replace(**NO_DETAIL)
    probe.material.update(preset)
    camera = probe.camera(1.0, 90.0)
    means = {}
    for varied in (True, False):
        probe.tile_variation = varied
        image, _ = probe.render(camera, "close")
        assert np.isfinite(image).all()
        means[varied] = float(luminance(image).mean())
    probe.tile_variation = True
    # Over ~100 tiles the copies' mean is the tile's; the borders favour no kind of grain.
    assert means[True] == pytest.approx(means[False], rel=0.02)


def _bowl_grains(size: int, preset: Preset) -> SandTextures:
    """A tile whose slope grows with position, (u, v) − ½: a bowl, convex in both axes."""
    centre = (np.arange(size) + 0.5) / size - 0.5
    v, u = np.meshgrid(centre, centre, indexing="ij")
    normal = np.stack([u, v, np.ones_like(u)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    blocks = (np.arange(size) // 8)[:, None] * 64 + (np.arange(size) // 8)[None, :]
    return SandTextures(
        albedo=np.full((size, size, 3), 0.4, dtype=np.float32),
        normal=normal.astype(np.float32),
        height=np.full((size, size), 0.5, dtype=np.float32),
        glint=np.zeros((size, size), dtype=np.float32),
        layer=np.zeros((size, size), dtype=np.int8),
        grain_id=blocks.astype(np.uint32),
        generation=preset.generation,
    )


def test_each_copy_turns_its_slopes_with_its_grains(gl_ctx, gl_clean):
    """A copy mirrored or turned must turn its grains' slopes with it: the bowl stays convex
    (its world slope grows along x and along z) in every copy, where slopes left in the tile's
    axes would fall across every mirrored one."""
    # 16 cells on the 64² tile: 4 texels each, so the material is built from the bowl itself
    # (a coarser tile would be built from its generation's grains generated finer).
    preset = Preset().replace(**NO_DETAIL, **{"generation.period": 16})
    material = SandMaterial(gl_ctx, 64)
    probe = MaterialProbe(material, 320, 180)
    probe.ripples = False
    try:
        material.update(preset, grains=_bowl_grains(64, preset))
        camera = probe.camera(0.5, 90.0)  # a tile is ~40 px; north (−z) is up in the frame
        fields = {}
        for varied in (True, False):
            probe.tile_variation = varied
            image, _ = probe.render(camera, "normals")
            fields[varied] = image * 2.0 - 1.0  # world normals
        for varied, n in fields.items():
            along_x = np.diff(n[..., 0], axis=1)  # columns: +x
            along_z = np.diff(n[..., 2], axis=0)  # rows downwards: +z
            for name, step in (("x", along_x), ("z", along_z)):
                # Within a copy, not across a border. Mip filtering across the tile's own seam
                # falls in ~5 % of pixels; slopes left in the tile's axes fall in ~40 %.
                ramp = step[np.abs(step) < 0.1]
                falling = float((ramp < -1e-3).mean())
                assert falling < 0.1, f"varied={varied}: slope falls along {name} in {falling:.1%}"
        # The copies differ from the repeating tile: the test sees turned copies.
        moved = np.abs(fields[True] - fields[False]).max(axis=-1) > 0.05
        assert moved.mean() > 0.3
    finally:
        probe.release()
        material.release()


def test_a_pixel_shows_the_copy_smaller_pixels_show_there(gl_ctx, gl_clean):
    """While grains span a pixel or more, the band where copies meet is as wide at every pixel
    size, so a frame's grains are those of the same view drawn 8× larger and averaged about as
    well with the copies as with the tile repeated."""
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.renderer import SandRenderer
    from sand_editor.render.sky import sky_at
    from tests.render.test_renderer import grain_detail_correlations

    width, height = 320, 180
    material = SandMaterial(gl_ctx, 512)
    flat = {"shading.ripple_strength": 0.0, **NO_DETAIL}
    material.update(Preset.load(bundled_preset("paper-default")).replace(**flat))
    renderer = SandRenderer(gl_ctx)
    renderer.set_material(material)
    renderer.relief = False  # the relief's own change with pixel size is measured apart
    try:
        terrain = renderer.terrain
        camera = camera_at_distance(
            0.3, 15.0, width / height, lambda x, z: float(terrain.height(x, z))
        )
        correlation = {}
        for varied in (True, False):
            renderer.tile_variation = varied
            at = grain_detail_correlations(renderer, camera, sky_at(12.0), (width, height))
            correlation[varied] = at[0]
    finally:
        renderer.release()
        material.release()
    # Measured 0.880 varied, 0.924 repeated; a band narrowed with the footprint gave 0.847.
    assert correlation[True] > correlation[False] - 0.06, correlation
