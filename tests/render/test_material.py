"""The sand material's behaviour, measured on the flat-plane probe with real GL."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from sand_editor.bench.probe import MaterialProbe
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from sand_editor.render.modes import MODES

pytestmark = pytest.mark.gl

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _probe(ctx, texture_size: int):
    material = SandMaterial(ctx, texture_size)
    material.update(Preset())
    probe = MaterialProbe(material, 96, 72)
    yield probe
    probe.release()
    material.release()


@pytest.fixture(scope="module")
def probe(gl_ctx):
    yield from _probe(gl_ctx, 256)


@pytest.fixture(autouse=True)
def _default_material(probe):
    probe.material.update(Preset())
    probe.glint_filter = "ours"
    probe.ground_truth_samples = 8
    yield
    probe.material.update(Preset())
    probe.glint_filter = "ours"


def shade(probe, distance, mode="full", pitch=45.0, **options):
    image, _ = probe.render(probe.camera(distance, pitch, **options), mode)
    assert np.isfinite(image).all(), f"{mode} at {distance} m has NaN or inf"
    return image


def test_glints_are_present_close_up(probe):
    assert shade(probe, 0.1, "glints").max() > 0
    # Glassy facets on every grain: many glint, brightly.
    probe.material.update(Preset().replace(**{"shading.facet_roughness": 0.08}))
    glints = shade(probe, 0.1, "glints") @ LUMINANCE
    diffuse = shade(probe, 0.1, "close") @ LUMINANCE - glints
    # Glints are highlights: the brightest are far above the diffuse sand around them.
    assert glints.max() > 2 * np.median(diffuse)


def test_sparkles_concentrate_the_expected_glint_into_few_bright_pixels(probe):
    sparkles = shade(probe, 0.3, "glints") @ LUMINANCE
    probe.glint_filter = "expected"
    expected = shade(probe, 0.3, "glints") @ LUMINANCE
    assert (expected > 0).mean() > 0.2
    assert 0 < (sparkles > 0).mean() < 0.2 * (expected > 0).mean()
    assert sparkles.max() > 10 * expected.max()


def test_no_glints_far_away_only_the_brdf(probe):
    far = shade(probe, 30.0, "far")
    full = shade(probe, 30.0, "full")
    np.testing.assert_allclose(full, far, rtol=1e-5, atol=1e-6)


def test_no_clear_grains_no_glints(probe):
    probe.material.update(Preset().replace(**{"shading.clear_grains": 0.0}))
    assert shade(probe, 0.1, "glints").max() == 0.0
    assert shade(probe, 10.0, "far").max() > 0.0  # the diffuse light is still there


def test_blend_weight_grows_with_distance(probe):
    means = [shade(probe, d, "blend").mean() for d in (0.05, 0.3, 1.0, 3.0, 10.0)]
    assert all(a < b for a, b in zip(means, means[1:], strict=False))
    # Within one grazing view, rows further up the image are further away.
    image = shade(probe, 2.0, "blend", pitch=10.0)[:, :, 0]
    rows = image[(image > 0).all(axis=1)].mean(axis=1)  # rows of sand, below the horizon
    assert rows.size > 10
    assert np.all(np.diff(rows[::-1]) >= -1e-6)


def test_lambert_differs_from_full(probe):
    full = shade(probe, 0.5, "full")
    lambert = shade(probe, 0.5, "lambert")
    assert np.abs(full - lambert).mean() > 0.01 * full.mean()
    # Lambert is the average colour on the flat macro normal: one value over the plane.
    assert np.ptp(lambert[..., 0]) < 1e-4


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize(("distance", "pitch"), [(0.001, 45.0), (1000.0, 45.0), (1.0, 1.0)])
def test_every_mode_is_finite_at_hard_views(probe, mode, distance, pitch):
    image = shade(probe, distance, mode, pitch)
    assert image.min() >= 0.0


def test_sun_below_the_horizon_is_finite_and_dark(probe):
    sun, radiance = probe.sun_direction.copy(), probe.sun_radiance.copy()
    try:
        probe.sun_direction = np.array([0.0, -0.3, -1.0])
        probe.sun_radiance = np.zeros(3)
        for mode in MODES:
            shade(probe, 0.2, mode)
        assert shade(probe, 0.2, "glints").max() == 0.0
    finally:
        probe.sun_direction, probe.sun_radiance = sun, radiance


def test_our_filtering_keeps_glint_energy_where_mipmapped_normals_lose_it(gl_ctx):
    # Grain textures fine enough to resolve the slopes of every grain (14 texels per cell).
    material = SandMaterial(gl_ctx, 512)
    material.update(Preset())
    probe = MaterialProbe(material, 160, 120)
    try:
        energies = {}
        for name in ("expected", "ours", "reference"):
            probe.glint_filter = name
            frames = [shade(probe, 3.0, "glints", shift_px=(0.37 * t, 0.61 * t)) for t in range(4)]
            energies[name] = np.mean([frame.mean() for frame in frames])
    finally:
        probe.release()
        material.release()
    expected = energies["expected"]
    assert expected > 0
    # The drawn sparkle's expectation is the moments' expected value.
    assert abs(energies["ours"] / expected - 1) < 0.15
    assert abs(energies["reference"] / expected - 1) > 0.5


def test_ours_flickers_less_than_no_filtering(probe):
    def change(name):
        probe.glint_filter = name
        frames = [
            shade(probe, 1.0, "glints", shift_px=(0.37 * t, 0.23 * t)) @ LUMINANCE for t in range(4)
        ]
        return np.abs(np.diff(np.stack(frames), axis=0)).mean()

    # Sparkles move with the surface (anchored), so their pixels change under motion, but less
    # than unfiltered grains, whose one tap jumps between slopes.
    assert change("ours") < change("none")


def test_updates_redo_only_what_changed(probe):
    material = probe.material
    grains = material._grains
    before = grains.normal_height.read()
    material.update(Preset().replace(**{"shading.facet_roughness": 0.5}))
    assert grains.normal_height.read() == before, "a shading change must not regenerate grains"
    built = material._built_for
    material.update(Preset().replace(**{"shading.clear_grains": 0.4}))
    assert material._built_for != built and grains.normal_height.read() == before
    material.update(Preset().replace(**{"generation.seed": 99}))
    assert grains.normal_height.read() != before, "new generation parameters, new grains"
    assert material._grains is grains, "drawn over the same textures: no objects made per edit"
    material.update(Preset())
    assert grains.normal_height.read() == before


def test_average_albedo_is_the_tile_mean(probe, gl_ctx):
    from sand_editor.generator import generate

    tex = generate(Preset(), 256, ctx=gl_ctx)
    np.testing.assert_allclose(probe.material.average_albedo, tex.average_albedo, rtol=5e-3)


def test_grazing_views_show_no_dark_patches_of_ripple_backs(probe):
    # Looking along the sand, some rippled normals face away from the eye; they must be bent
    # towards it, not shaded black (the BRDF is zero for a normal facing away).
    image = shade(probe, 0.2, "far", pitch=3.0) @ LUMINANCE
    sand = image[image > 0]
    assert sand.size > 1000
    assert sand.min() > 0.4 * np.median(sand)


def test_release_frees_every_gl_object_it_made(gl_ctx):
    material = SandMaterial(gl_ctx, 64)
    material.update(Preset())
    made = [v for k, v in vars(material).items() if k != "ctx" and hasattr(v, "mglo")]
    made += [v for v in vars(material._grains).values() if hasattr(v, "mglo")]
    # 36 cells on a 64² tile: its grains are generated finer too (supersampling).
    made += [v for v in vars(material._fine).values() if hasattr(v, "mglo")]
    assert len(made) >= 10, made
    material.release()
    alive = [obj for obj in made if type(obj.mglo).__name__ != "InvalidObject"]
    assert not alive, f"left alive: {alive}"


def _sparkles(probe, camera, reference_frame=None):
    glints = probe.render(camera, "glints")[0] @ LUMINANCE
    assert np.isfinite(glints).all()
    return glints


def test_sparkles_are_bright_few_and_where_the_expected_glint_is(probe):
    camera = probe.camera(0.3)
    sparkle = _sparkles(probe, camera)
    probe.glint_filter = "expected"
    expected = _sparkles(probe, camera)
    lit = sparkle > 0
    assert 0 < lit.mean() < 0.2
    # A sparkle only where some grain can glint there, and above that pixel's expectation.
    assert (expected[lit] > 0).all()
    # Facets come in sizes: the small ones lift their pixel a little, the large ones far more.
    ratio = sparkle[lit] / expected[lit]
    assert np.median(ratio) > 1.5 and np.quantile(ratio, 0.75) > 4


def test_sparkles_stay_on_the_surface_under_sub_pixel_camera_motion(probe):
    # Shift the camera by whole pixels along the image: an anchored sparkle moves with the
    # image, one drawn in screen space would stay or reshuffle.
    still = _sparkles(probe, probe.camera(0.3))
    moved = _sparkles(probe, probe.camera(0.3, shift_px=(3.0, 0.0)))
    a, b = still[:, :-3] > 0, moved[:, 3:] > 0
    assert a.sum() > 3
    overlap = (a & b).sum() / max(a.sum(), 1)
    assert overlap > 0.6, overlap
    # Without the shift compensation they do not line up: the pattern is not tied to the screen.
    assert (a & (moved[:, :-3] > 0)).sum() / max(a.sum(), 1) < 0.5 * overlap


def test_the_two_eyes_of_a_stereo_pair_see_different_sparkles(probe):
    from sand_editor.render.camera import Camera, look_at_matrix

    base = probe.camera(0.3)
    eye = base.eye
    right = np.cross(base.forward.astype(np.float64), (0.0, 1.0, 0.0))
    right /= np.linalg.norm(right)
    target = eye + 0.3 * base.forward.astype(np.float64)

    def eye_camera(offset):
        position = eye + offset * right
        # Both eyes converge on the same point; the surface there is seen from 63 mm apart.
        return Camera(look_at_matrix(position, target), base.projection, position)

    left, right_eye = (_sparkles(probe, eye_camera(s)) for s in (-0.0315, 0.0315))
    assert (left > 0).sum() > 3 and (right_eye > 0).sum() > 3
    both = ((left > 0) & (right_eye > 0)).sum()
    assert both < 0.5 * min((left > 0).sum(), (right_eye > 0).sum())


@pytest.fixture(scope="module")
def fine_probe(gl_ctx):
    # Grain textures fine enough that a 200 µm facet is under a texel: the ground truth's facets
    # then see the grains as the renderer does.
    yield from _probe(gl_ctx, 512)


def _lower_half_glints(probe, glint_filter, distance, views=4):
    from sand_editor.render.camera import camera_at_distance

    probe.glint_filter = glint_filter
    try:
        frames = []
        for view in range(views):
            target = (0.37 * view * distance, 0.23 * view * distance)
            camera = camera_at_distance(distance, 45.0, 96 / 72, target_xz=target)
            image = probe.render(camera, "glints", lower_half=True)[0] @ LUMINANCE
            assert np.isfinite(image).all()
            frames.append(image[36:])
        return np.stack(frames)
    finally:
        probe.glint_filter = "ours"


@pytest.mark.slow
def test_sparkles_appear_where_the_ground_truth_has_them_with_its_statistics(fine_probe):
    ours = _lower_half_glints(fine_probe, "ours", 1.0)
    truth = _lower_half_glints(fine_probe, "ground-truth", 1.0)
    expected = _lower_half_glints(fine_probe, "ground-truth-mean", 1.0)
    # Only where some facet could mirror the sun.
    assert (expected[ours > 0] > 0).all()
    # Per-pixel spread and energy of the ground truth's sparkles.
    cv = {name: img.std() / img.mean() for name, img in (("ours", ours), ("truth", truth))}
    assert abs(cv["ours"] / cv["truth"] - 1) < 0.3, cv
    # With every grain clear, the footprint moments' Gaussian-with-hole holds less light than the
    # exact texels here, and this small probe draws only a few hundred sparkles. A patch spreads
    # its chance evenly over its facets, where the truth's facets mirror on the grains that face
    # the half vector: with about five facets to a largest facet's area (their sizes), the
    # truth's crowd into fewer pixels. Measured: energy 0.84, spread 0.82 and sparkling pixels
    # 1.52 of the ground truth's (with one size of facet: 0.76, 1.06 and 0.87).
    assert abs(ours.mean() / truth.mean() - 1) < 0.5
    assert 0.5 < (ours > 0).mean() / (truth > 0).mean() < 2.0
    expected_ours = _lower_half_glints(fine_probe, "ours-mean", 1.0)
    assert abs(expected_ours.mean() / expected.mean() - 1) < 0.25
    # Where the ground truth sparkles more (bands of the view whose half vectors meet more
    # facets), so do ours.
    bands = lambda img: (img > 0).reshape(img.shape[0], 6, 6, 96).mean(axis=(0, 2, 3))  # noqa: E731
    assert np.corrcoef(bands(ours), bands(truth))[0, 1] > 0.5


@pytest.mark.parametrize("glint_filter", ["ground-truth", "ours-mean", "ground-truth-mean"])
@pytest.mark.parametrize(("distance", "pitch"), [(0.001, 45.0), (1000.0, 45.0), (1.0, 1.0)])
def test_benchmark_filters_are_finite_at_hard_views(probe, glint_filter, distance, pitch):
    probe.glint_filter = glint_filter
    image = shade(probe, distance, "glints", pitch)
    assert image.min() >= 0.0


@pytest.mark.slow
def test_sparkles_flicker_no_more_than_the_ground_truth_under_sub_pixel_motion(fine_probe):
    def flicker(glint_filter):
        fine_probe.glint_filter = glint_filter
        try:
            frames = np.stack(
                [
                    (shade(fine_probe, 1.0, "glints", shift_px=(0.37 * t, 0.23 * t)) @ LUMINANCE)[
                        36:
                    ]
                    for t in range(4)
                ]
            )
        finally:
            fine_probe.glint_filter = "ours"
        return np.abs(np.diff(frames, axis=0)).mean() / frames.mean()

    # Pooled over three ripple orientations: this small frame's ratio alone moves between 0.97
    # and 1.21 with which ripples it sees (measured at five winds).
    ours, truth = [], []
    for wind in (30.0, 150.0, 270.0):
        fine_probe.material.update(Preset().replace(**{"shading.wind_direction": wind}))
        ours.append(flicker("ours"))
        truth.append(flicker("ground-truth"))
    fine_probe.material.update(Preset())
    ours, truth = float(np.mean(ours)), float(np.mean(truth))
    assert truth > 0.2  # sparkles do cross pixel edges as the camera moves
    # As much as the facets themselves (pooled: 1.08), far from a redraw of every sparkle in
    # every frame (2 on this scale).
    assert ours < 1.2 * truth, (ours, truth)


def test_a_material_built_with_blending_left_on_is_the_one_built_with_it_off(gl_clean):
    """A host's paint callback may leave blending on (Qt does): the build passes overwrite."""
    preset = Preset().replace(**{"shading.clear_grains": 0.6})
    reference = SandMaterial(gl_clean, 64)
    updated = SandMaterial(gl_clean, 64)
    made = None
    try:
        reference.update(preset)
        updated.update(Preset())
        gl_clean.enable(moderngl.BLEND)
        gl_clean.blend_func = moderngl.DEFAULT_BLENDING
        updated.update(preset)  # a glint selection change: the build pass alone
        gl_clean.enable(moderngl.BLEND)
        made = SandMaterial(gl_clean, 64)
        made.update(preset)  # grains and build
        for material in (made, updated):
            np.testing.assert_array_equal(material.average_albedo, reference.average_albedo)
            for name in ("albedo", "glint_moments", "spread_moments", "hole_moments"):
                assert getattr(material, name).read() == getattr(reference, name).read(), name
        assert reference.average_albedo.min() > 0.05  # the check sees a coloured tile
    finally:
        gl_clean.disable(moderngl.BLEND)
        for material in (reference, updated, made):
            if material is not None:
                material.release()


def test_paced_generation_draws_the_same_grains_in_bands(gl_ctx):
    from sand_editor.render.material import GENERATION_BAND_ROWS

    preset = Preset()
    whole, paced = SandMaterial(gl_ctx, texture_size=256), SandMaterial(gl_ctx, texture_size=256)
    pauses = []
    try:
        whole.update(preset)
        paced.update(preset, between_bands=lambda: pauses.append(1))
        assert len(pauses) == 256 // GENERATION_BAND_ROWS
        for name in ("albedo", "glint_moments", "spread_moments", "hole_moments"):
            assert getattr(paced, name).read() == getattr(whole, name).read(), name
        # Shading-only edits draw no grains, so they do not pause.
        paced.update(preset.replace(**{"shading.sss": 0.5}), between_bands=lambda: pauses.append(1))
        assert len(pauses) == 256 // GENERATION_BAND_ROWS
    finally:
        whole.release()
        paced.release()


def test_supersampling_gives_every_grain_cell_enough_points():
    from sand_editor.generator.sizes import MAX_SIZE, MIN_SIZE
    from sand_editor.preset import FIELDS
    from sand_editor.render.material import MIN_CELL_TEXELS, supersampling

    assert supersampling(1024, 36) == 1
    assert supersampling(256, 256) == 4
    assert supersampling(64, 36) == 4
    periods = next(spec for spec in FIELDS if spec.path == "generation.period")
    size = MIN_SIZE
    while size <= MAX_SIZE:
        for period in range(int(periods.minimum), int(periods.maximum) + 1):
            factor = supersampling(size, period)
            assert size * factor >= MIN_CELL_TEXELS * period
            # The least such power of two.
            assert factor == 1 or size * factor // 2 < MIN_CELL_TEXELS * period
        size *= 2


_TEXTURES = ("albedo", "glint_moments", "spread_moments", "hole_moments", "normal_moments")


def _level(texture, level: int) -> np.ndarray:
    dtype = np.float16 if texture.dtype == "f2" else np.float32
    size = texture.width >> level
    return np.frombuffer(texture.read(level=level), dtype=dtype).reshape(size, size, -1)


def test_a_tile_too_coarse_for_its_grains_is_built_as_a_finer_tile_mipmapped(gl_ctx):
    # 256 cells on a 256² tile: each texel must hold the mean of the grains over it, as level
    # 2 of the 1024² tile does, not one point of them.
    # Faceted grains on a regular grid: every cell the same, its slopes a few discrete ones.
    preset = Preset().replace(
        **{
            "generation.period": 256,
            "generation.jitter": 0.0,
            "generation.threshold": 0.0,
            "generation.roundness": 0.01,
        }
    )
    coarse, fine = SandMaterial(gl_ctx, 256), SandMaterial(gl_ctx, 1024)
    try:
        coarse.update(preset)
        fine.update(preset)
        # The grains are there, and their slopes spread within a texel.
        w, _, _, _ = _level(fine.glint_moments, 2).transpose(2, 0, 1)
        wb2 = _level(fine.spread_moments, 2)[..., 0]
        wb = _level(fine.glint_moments, 2)[..., 1]
        assert w.mean() > 0.5
        assert (wb2 * w - wb * wb).mean() > 1e-3
        for name in _TEXTURES:
            for level in (0, 3):
                ours = _level(getattr(coarse, name), level).astype(np.float64)
                truth = _level(getattr(fine, name), level + 2).astype(np.float64)
                scale = max(float(np.abs(truth).max()), 1e-6)
                assert np.abs(ours - truth).max() <= 2e-3 * scale, (name, level)
        # The diffuse light's correction is measured on those grains' own normals too.
        tables = [
            np.frombuffer(m.diffuse_correction_texture.read(), np.float32) for m in (coarse, fine)
        ]
        np.testing.assert_allclose(*tables, atol=0.01)
    finally:
        coarse.release()
        fine.release()


def test_finer_grains_are_held_only_while_needed_and_released(gl_clean):
    from tests.gl_objects import live_gl_objects

    material = SandMaterial(gl_clean, 256)
    try:
        material.update(Preset())
        resolved = live_gl_objects(gl_clean)
        assert material._fine is None
        for _ in range(3):
            material.update(Preset().replace(**{"generation.period": 200}))
            assert material._fine is not None and material._fine.size == 1024
            material.update(Preset())
            assert material._fine is None
            assert live_gl_objects(gl_clean) == resolved
        # Another material's finer grains are copied with its grains, not drawn again.
        material.update(Preset().replace(**{"generation.period": 200}))
        twin = SandMaterial(gl_clean, 256)
        twin.update(Preset().replace(**{"generation.period": 200}), grains=material)
        assert twin._fine.normal_height.read() == material._fine.normal_height.read()
        twin.release()
    finally:
        material.release()
