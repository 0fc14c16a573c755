from __future__ import annotations

import numpy as np
import pytest

from sand_editor.render.terrain import MAX_SLOPE_DEG, DuneTerrain, sphere_mesh


@pytest.fixture(params=[0, 7])
def terrain(request):
    return DuneTerrain(seed=request.param)


def finite_difference_normals(terrain, x, z, step=1e-4):
    dhdx = (terrain.height(x + step, z) - terrain.height(x - step, z)) / (2 * step)
    dhdz = (terrain.height(x, z + step) - terrain.height(x, z - step)) / (2 * step)
    n = np.stack([-dhdx, np.ones_like(dhdx), -dhdz], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def test_mesh_normals_match_finite_differences(terrain, strict_numpy):
    mesh = terrain.mesh((130.0, -75.0), 200.0, 33)
    x, z = mesh["uv"][:, 0].astype(np.float64), mesh["uv"][:, 1].astype(np.float64)
    gx, gz = terrain.gradient(x, z)
    analytic = np.stack([-gx, np.ones_like(gx), -gz], axis=-1)
    analytic /= np.linalg.norm(analytic, axis=-1, keepdims=True)
    assert np.abs(analytic - finite_difference_normals(terrain, x, z)).max() < 1e-6
    assert np.abs(mesh["normal"] - analytic).max() < 1e-6


def test_dunes_are_metres_high_and_no_steeper_than_sand_stands(terrain, strict_numpy):
    x, z = np.random.default_rng(5).uniform(-3000.0, 3000.0, size=(2, 200_000))
    h = terrain.height(x, z)
    assert 2.0 < h.max() - h.min() < 15.0
    slope = np.degrees(np.arctan(np.hypot(*terrain.gradient(x, z))))
    assert slope.max() < MAX_SLOPE_DEG + 1e-9
    assert slope.max() > 15.0, "dunes, not a plain"


def test_mesh_attributes_are_consistent(terrain):
    mesh = terrain.mesh((0.0, 0.0), 50.0, 9)
    n = len(mesh["position"])
    assert n == 81 and mesh["index"].dtype == np.uint32 and mesh["index"].max() == n - 1
    assert len(mesh["index"]) == 8 * 8 * 6
    for name, width in (("position", 3), ("normal", 3), ("tangent", 3), ("uv", 2)):
        assert mesh[name].shape == (n, width) and mesh[name].dtype == np.float32
    assert np.allclose(np.linalg.norm(mesh["normal"], axis=1), 1.0, atol=1e-6)
    assert np.allclose(np.linalg.norm(mesh["tangent"], axis=1), 1.0, atol=1e-6)
    assert np.abs(np.sum(mesh["normal"] * mesh["tangent"], axis=1)).max() < 1e-6
    assert np.all(mesh["tangent"][:, 0] > 0), "tangents run along +x"
    assert np.allclose(mesh["uv"], mesh["position"][:, [0, 2]])
    expected_height = terrain.height(mesh["uv"][:, 0], mesh["uv"][:, 1])
    assert np.allclose(mesh["position"][:, 1], expected_height, atol=1e-5)


def test_no_nan_at_extreme_coordinates(terrain, strict_numpy):
    mesh = terrain.mesh((1e7, -1e7), 1e3, 5)
    for name in ("position", "normal", "tangent", "uv"):
        assert np.isfinite(mesh[name]).all()


def test_radial_mesh_relative_to_origin_keeps_millimetre_detail(terrain):
    center = (5000.0, -3000.0)
    origin = np.array([center[0], terrain.height(*center), center[1]])
    mesh = terrain.radial_mesh(center, 1e-5, 2000.0, 32, origin=origin)
    local = mesh["position"].astype(np.float64)
    radius = np.hypot(local[:, 0], local[:, 2])
    assert 0 < np.sort(np.unique(radius.round(9)))[1] < 2e-5
    assert radius.max() >= 2000.0 * 0.999
    assert mesh["index"].max() == len(local) - 1
    # Near the centre, the relative positions resolve micrometres despite float32.
    near = radius < 1e-4
    world = local[near] + origin
    assert np.allclose(world[:, 1], terrain.height(world[:, 0], world[:, 2]), atol=1e-7)


def test_ray_hit_lands_on_the_ground(terrain):
    hit = terrain.ray_hit((3.0, 50.0, -2.0), (0.3, -1.0, 0.1), 500.0)
    assert hit is not None
    assert hit[1] == pytest.approx(terrain.height(hit[0], hit[2]), abs=1e-6)
    assert terrain.ray_hit((0.0, 50.0, 0.0), (0.0, 1.0, 0.0), 500.0) is None


def test_sphere_mesh_frame():
    mesh = sphere_mesh((1.0, 2.0, 3.0), 0.5, 16)
    offsets = mesh["position"] - np.array([1.0, 2.0, 3.0], dtype=np.float32)
    assert np.allclose(np.linalg.norm(offsets, axis=1), 0.5, atol=1e-6)
    assert np.allclose(offsets / 0.5, mesh["normal"], atol=1e-5)
    assert np.allclose(np.linalg.norm(mesh["tangent"], axis=1), 1.0, atol=1e-6)
    assert np.abs(np.sum(mesh["normal"] * mesh["tangent"], axis=1)).max() < 1e-6
    # cross(tangent, normal) points to +v (north), the terrain's handedness.
    bitangent = np.cross(mesh["tangent"], mesh["normal"])
    equator = np.abs(mesh["normal"][:, 1]) < 1e-6
    assert np.all(bitangent[equator, 1] > 0.99)
    assert mesh["index"].max() == len(mesh["position"]) - 1
