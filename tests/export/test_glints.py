"""The glint model's numbers for other renderers: the facet count the shaders use, the glTF
file's extras and Unreal Substrate's GlintValue map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor import gl
from sand_editor.export import maps as material
from sand_editor.export.glints import check_finite, facets_per_tile, glint_parameters, log_density
from sand_editor.export.gltf import PatchOptions, build_gltf
from sand_editor.export.images import decode
from sand_editor.export.sets import MapFormats, texture_set
from sand_editor.generator import generate
from sand_editor.preset import FIELDS, GLTF_EXTRAS_KEY, Preset
from sand_editor.render.material import (
    FACET_SIZE_RANGE,
    FACETS_PER_LARGEST,
    SHADER_DEFINES,
    surface_defines,
)
from sand_editor.resources import bundled_preset

SIZE = 64
SHIPPED = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")


@pytest.fixture(scope="module")
def paper():
    preset = Preset.load(bundled_preset("paper-default"))
    textures = generate(preset, SIZE, backend="reference")
    return preset, material.material_maps(preset, textures)


def test_facets_per_largest_counts_the_shaders_facet_sizes():
    # Edges log-uniform over [a/R, a] with each octave an equal share of the area: integrate
    # facets (share per ln r over the facet's area r²) numerically.
    log_r = np.linspace(-math.log(FACET_SIZE_RANGE), 0.0, 200_001)
    density = np.exp(-2.0 * log_r) / math.log(FACET_SIZE_RANGE)
    integral = float(np.sum((density[1:] + density[:-1]) * np.diff(log_r)) / 2.0)
    assert integral == pytest.approx(FACETS_PER_LARGEST, rel=1e-6)
    # The shaders take the same number, not their own formula of it.
    assert float(SHADER_DEFINES["FACETS_PER_LARGEST"]) == FACETS_PER_LARGEST
    text = gl.shader_text("terrain.glsl", {**surface_defines(), "FRAGMENT_SHADER": 1})
    assert f"#define FACETS_PER_LARGEST {FACETS_PER_LARGEST!r}" in text
    assert "const float FACETS_PER_LARGEST" not in text


@pytest.mark.parametrize("name", SHIPPED)
def test_the_shipped_sands_log_densities_lie_where_real_time_glint_models_work(name):
    preset = Preset.load(bundled_preset(name))
    clear = log_density(preset.shading.clear_grains, facets_per_tile(preset))
    assert 5.0 <= float(clear) <= 25.0  # Chermain et al. 2020's range, sparse to dense


def test_the_gltf_material_carries_the_glint_parameters(paper):
    preset, maps = paper
    gltf, _, _ = build_gltf(preset, maps, PatchOptions(size_m=1.0))
    glints = gltf.materials[0].extras[GLTF_EXTRAS_KEY]["glints"]
    assert glints["largest_facet_m"] == preset.largest_facet_m
    assert glints["facets_per_largest"] == FACETS_PER_LARGEST
    assert glints["tiles_per_m"] == preset.shading.uv_scale
    share = float(np.mean(maps.specular))
    expected = math.log(
        share * FACETS_PER_LARGEST / (preset.largest_facet_m * preset.shading.uv_scale) ** 2
    )
    assert glints["log_microfacet_density"] == pytest.approx(expected, rel=1e-6)


def test_unreal_glint_value_is_the_log_density_of_each_texel(paper):
    preset, maps = paper
    files = texture_set(preset, maps, "unreal", MapFormats(), "sand")
    value = decode(files["sand_GlintValue.exr"])
    assert value.dtype == np.float32 and value.shape == (SIZE, SIZE)
    assert np.isfinite(value).all() and value.min() >= 0.0
    expected = material.image_rows(log_density(maps.specular, facets_per_tile(preset)))
    np.testing.assert_allclose(value, expected, rtol=1e-6)
    # Mirroring texels read the clear grains' density; gaps and dull grains none (0).
    clear = material.image_rows(maps.specular) > 0.5
    assert value[clear].min() > 10.0 and (value[~clear] < value[clear].min()).all()
    readme = files["README.txt"].decode()
    assert "Glint Value = GlintValue" in readme and "Glint UV = TexCoord[0]" in readme
    # The other engines' sets have no such map.
    assert not any("Glint" in n for n in texture_set(preset, maps, "godot", MapFormats(), "s"))


def test_no_facets_and_extreme_sizes_give_finite_parameters():
    preset = Preset.load(bundled_preset("pale-quartz"))
    extremes = [{"shading.clear_grains": 0.0}]
    for path in ("shading.facet_size", "shading.uv_scale"):
        spec = next(spec for spec in FIELDS if spec.path == path)
        extremes += [{path: spec.minimum}, {path: spec.maximum}]
    for changes in extremes:
        varied = preset.replace(**changes)
        for specular in (np.zeros((4, 4)), np.ones((4, 4))):
            params = check_finite(glint_parameters(varied, specular))
            assert params["log_microfacet_density"] >= 0.0, changes
    assert float(log_density(0.0, 1e12)) == 0.0
