"""The relief bench: its mesh is the relief's height field (top at the plane, gaps half a grain
cell down, seamless, unit normals up), and the command writes every view's numbers, with the
relief's shadows where Mitsuba's geometry has them."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _bench_run import run_bench

from sand_editor.bench.relief_reference import DISTANCES, SUN_ELEVATIONS, relief_mesh
from sand_editor.generator import generate
from sand_editor.preset import Preset


@pytest.fixture(scope="module")
def grains():
    return generate(Preset(), 64, backend="reference")


def test_the_mesh_is_the_relief_height_field(grains):
    n, uv_scale = grains.size, 8.0
    mesh = relief_mesh(grains, uv_scale)
    cell = 1.0 / uv_scale / grains.generation.period
    positions, normals = mesh["positions"], mesh["normals"]
    assert positions.shape == ((n + 1) ** 2, 3) and mesh["faces"].shape == (2 * n * n, 3)
    assert mesh["depth_m"] == pytest.approx(0.5 * cell)
    y = positions[:, 1]
    # Top at the plane (only the tallest grain reaches it), gaps at the bottom.
    assert y.max() <= 0.0 and y.max() > -0.2 * mesh["depth_m"]
    assert (grains.layer < 0).any()
    assert y.min() == pytest.approx(-0.5 * cell, rel=1e-5)
    grid = y.reshape(n + 1, n + 1)
    assert np.array_equal(grid[0], grid[-1]) and np.array_equal(grid[:, 0], grid[:, -1])
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    assert (normals[:, 1] > 0).all()  # tangent-space z is world +y
    # The last vertex is one tile on from the first: texel centres of one period.
    span = positions[-1] - positions[0]
    assert span[0] == pytest.approx(1.0 / uv_scale) and span[2] == pytest.approx(1.0 / uv_scale)
    # Every triangle faces up.
    a, b, c = (positions[mesh["faces"][:, k]] for k in range(3))
    assert (np.cross(b - a, c - a)[:, 1] > 0).all()
    assert relief_mesh(grains, uv_scale, flat=True)["positions"][:, 1].max() == 0.0


def test_texture_v_runs_along_world_z_and_so_do_the_normals(grains):
    mesh = relief_mesh(grains, 8.0)
    n = grains.size
    # Vertex (row 0, column 1) lies one texel along +x, (row 1, column 0) one along +z.
    p = mesh["positions"]
    assert p[1, 0] > p[0, 0] and p[n + 1, 2] > p[0, 2]
    assert np.allclose(mesh["normals"][n + 2, [0, 2]], grains.normal[1, 1, :2], atol=1e-5)
    assert np.allclose(mesh["albedo"][n + 2], grains.albedo[1, 1])


@pytest.mark.gl
@pytest.mark.slow
def test_relief_bench_writes_every_view_and_shadows_like_mitsuba(tmp_path):
    json_path, plot_path = tmp_path / "relief.json", tmp_path / "relief.png"
    result = run_bench("relief", "--json", str(json_path), "--plot", str(plot_path), timeout=600)
    assert "| paper-default | 5 cm | 10° |" in result.stdout
    rows = {(r["distance_m"], r["sun_elevation_deg"]): r
            for r in json.loads(json_path.read_text())["rows"]}  # fmt: skip
    assert set(rows) == {(d, e) for d in DISTANCES for e in SUN_ELEVATIONS}
    assert plot_path.stat().st_size > 0
    for row in rows.values():
        numbers = [row["cell_px"], row["ratio_relief"], row["ratio_flat"]]
        for measure in ("in_shadow", "dark", "light_lost", "mean_luminance"):
            numbers += row[measure].values()
        assert all(math.isfinite(x) for x in numbers), row
        assert row["cell_px"] > 5.0  # the relief at full weight
        # Without relief nothing casts a shadow, in either renderer.
        assert row["in_shadow"]["ours_flat"] == row["in_shadow"]["mitsuba_flat"] == 0.0
    for distance in DISTANCES:
        low, high = rows[distance, 10.0], rows[distance, 30.0]
        assert low["in_shadow"]["ours_relief"] > low["in_shadow"]["ours_flat"]
        assert low["dark"]["ours_relief"] > low["dark"]["ours_flat"]
        assert low["in_shadow"]["mitsuba_relief"] > high["in_shadow"]["mitsuba_relief"]
        assert low["in_shadow"]["ours_relief"] > high["in_shadow"]["ours_relief"]
