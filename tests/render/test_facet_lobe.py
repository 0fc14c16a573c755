"""The facets' lobe rotated with each grain (render/facet_lobe.py), the ratio of its light to
the slope moments' sheared lobe that the material measures on its grains, and the shader's use
of it."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.bench.probe import MaterialProbe
from sand_editor.preset import Preset
from sand_editor.render.facet_lobe import (
    LOBE_ALPHAS,
    LOBE_RANGE,
    LOBE_TILTS_DEG,
    lobe_correction,
    lobe_row,
    rotated_density,
    sheared_density,
)
from sand_editor.render.material import SandMaterial
from sand_editor.resources import bundled_preset

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _slope_grid(extent: float, steps: int) -> tuple[np.ndarray, float]:
    axis = np.linspace(-extent, extent, steps)
    s = np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1)
    return s, (axis[1] - axis[0]) ** 2


@pytest.mark.parametrize("alpha", [0.05, 0.2, 0.45])
@pytest.mark.parametrize("grain", [(0.0, 0.0), (0.4, -0.2), (-0.9, 0.6)])
def test_the_rotated_lobe_holds_one_grains_facets(alpha, grain):
    # Beckmann about a tilted grain's normal, in the ground's slope space: all its facets are
    # there (it integrates to 1), and its mean facet normal is the grain's.
    b = np.array(grain)
    s, cell = _slope_grid(12.0, 1601)
    density = rotated_density(s, b, alpha)
    assert np.isfinite(density).all() and density.min() >= 0.0
    assert density.sum() * cell == pytest.approx(1.0, abs=0.01)
    normals = np.concatenate([s, np.ones(s.shape[:-1] + (1,))], axis=-1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    # Weighted by facet area projected on the grain: its mean normal is the grain's.
    grain_normal = np.append(b, 1.0) / np.linalg.norm(np.append(b, 1.0))
    projected = density * (normals @ grain_normal) / normals[..., 2]
    mean = (projected[..., None] * normals).sum(axis=(0, 1))
    assert mean / np.linalg.norm(mean) == pytest.approx(grain_normal, abs=0.01)


def test_on_a_flat_grain_the_two_lobes_are_one():
    s, _ = _slope_grid(3.0, 61)
    for alpha in (0.01, 0.3, 1.0):
        flat = np.zeros(2)
        assert rotated_density(s, flat, alpha) == pytest.approx(sheared_density(s, flat, alpha))


def test_the_sheared_lobe_misses_a_tilted_grains_spread():
    # Tilted 45°: rotated with the grain, the lobe is wider along the tilt (slopes stretch by
    # 1/cos²) and lower at its peak; the moments' Gaussian keeps its width.
    b = np.array([1.0, 0.0])
    assert rotated_density(b, b, 0.2) == pytest.approx(sheared_density(b, b, 0.2) / 2**1.5)
    along = b + np.array([0.3, 0.0])
    assert rotated_density(along, b, 0.2) > sheared_density(along, b, 0.2)


def test_the_correction_is_one_where_grains_are_flat_or_none_is_clear():
    slopes = np.zeros((500, 2))
    assert np.allclose(lobe_correction(slopes, np.ones(500)), 1.0)
    rng = np.random.default_rng(1)
    tilted = rng.normal(0.0, 0.8, (500, 2))
    assert np.all(lobe_correction(tilted, np.zeros(500)) == 1.0)


def test_the_correction_of_ball_caps_grows_with_roughness_and_stays_finite():
    from sand_editor.export.maps import clear_weights
    from sand_editor.generator import generate

    preset = Preset.load(bundled_preset("red-desert"))
    textures = generate(preset, 128)
    normal = textures.normal.reshape(-1, 3)
    table = lobe_correction(normal[:, :2] / normal[:, 2:], clear_weights(preset, textures))
    assert table.shape == (LOBE_ALPHAS.size, LOBE_TILTS_DEG.size)
    assert np.isfinite(table).all()
    assert table.min() >= LOBE_RANGE[0] and table.max() <= LOBE_RANGE[1]
    # Towards the zenith the rotated lobes of the tilted caps pile up more facets: more so the
    # rougher the facets (α 0.1 → 1), and by α² for smoother ones.
    zenith = table[:, 0]
    assert np.all(np.diff(zenith) > 0.0)
    assert 1.0 < zenith[0] < 1.1 and zenith[-1] > 1.8


def test_a_roughness_takes_its_row_between_the_tables():
    table = 1.0 + np.outer(np.arange(1.0, 1.0 + LOBE_ALPHAS.size), np.linspace(0.1, 0.2, 13))
    for i, alpha in enumerate(LOBE_ALPHAS):
        assert lobe_row(table, alpha) == pytest.approx(table[i])
    # Halfway between two rows in log α: halfway between the rows.
    middle = np.sqrt(LOBE_ALPHAS[1] * LOBE_ALPHAS[2])
    assert lobe_row(table, middle) == pytest.approx(0.5 * (table[1] + table[2]))
    # Smoother facets than the first row: its departure from 1 by (α/α₀)².
    half = 0.5 * LOBE_ALPHAS[0]
    assert lobe_row(table, half) == pytest.approx(1.0 + 0.25 * (table[0] - 1.0))
    assert lobe_row(table, 1e-6) == pytest.approx(np.ones(13), abs=1e-9)


@pytest.mark.gl
def test_the_shader_scales_the_moments_density_by_the_table(gl_ctx):
    material = SandMaterial(gl_ctx, 128)
    probe = MaterialProbe(material, 48, 27)
    try:
        probe.glint_filter = "ours-mean"
        means = {}
        for alpha in (0.3, 0.05):
            material.update(Preset().replace(**{"shading.facet_roughness": alpha}))
            measured = material.lobe_correction.copy()
            camera = probe.camera(3.0, 45.0)
            for name, table in (
                ("ones", np.ones_like(measured)),
                ("x1.5", 1.5 * np.ones_like(measured)),
            ):
                material.lobe_correction = table
                for mode in ("glints", "far"):
                    image, _ = probe.render(camera, mode, lower_half=True)
                    means[alpha, name, mode] = float(
                        (image[image.shape[0] // 2 :] @ LUMINANCE).mean()
                    )
            material.lobe_correction = measured
        # Above the table's first roughness the density takes the table's value; below it the
        # departure from 1 shrinks as α² (0.05 is half the first row's 0.1: a quarter).
        assert means[0.3, "x1.5", "glints"] == pytest.approx(
            1.5 * means[0.3, "ones", "glints"], rel=1e-3
        )
        assert means[0.05, "x1.5", "glints"] == pytest.approx(
            1.125 * means[0.05, "ones", "glints"], rel=1e-3
        )
        # The far shading's specular follows it alike.
        far_gain = means[0.3, "x1.5", "far"] - means[0.3, "ones", "far"]
        assert far_gain == pytest.approx(0.5 * means[0.3, "ones", "glints"], rel=0.05)
    finally:
        probe.release()
        material.release()
