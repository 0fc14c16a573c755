from __future__ import annotations

import numpy as np
import pytest

from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.terrain import DuneTerrain

TERRAIN = DuneTerrain(seed=3)


def project(camera: Camera, point, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    view = camera.view_relative_to(origin)
    clip = camera.projection.astype(np.float64) @ view @ [*(np.subtract(point, origin)), 1.0]
    return clip[:3] / clip[3]


@pytest.mark.parametrize("distance", [1e-3, 1.0, 1000.0])
@pytest.mark.parametrize("pitch", [1.0, 35.0, 90.0])
@pytest.mark.parametrize("target_xz", [(0.0, 0.0), (12.5, -40.0)])
def test_camera_at_distance_looks_at_the_ground_point_from_that_distance(
    distance, pitch, target_xz
):
    camera = camera_at_distance(
        distance, pitch, 4 / 3, TERRAIN.height, target_xz=target_xz, heading_deg=30.0
    )
    assert np.isfinite(camera.view).all() and np.isfinite(camera.projection).all()
    target = np.array([target_xz[0], TERRAIN.height(*target_xz), target_xz[1]])
    eye = camera.position.astype(np.float64)
    assert np.linalg.norm(eye - target) == pytest.approx(distance, rel=1e-3)
    # Millimetres from the sand far from the world origin, only origin-relative maths is precise
    # enough; near the origin the float32 matrices alone are.
    origin = target if target_xz != (0.0, 0.0) else (0.0, 0.0, 0.0)
    ndc = project(camera, target, origin)
    assert np.abs(ndc[:2]).max() < 1e-3
    assert -1.0 < ndc[2] < 1.0, "the target is clipped by the near or far plane"
    down = -camera.forward[1]
    assert np.degrees(np.arcsin(down)) == pytest.approx(pitch, abs=0.05)


def test_look_at_inverts_to_its_eye_and_forward():
    camera = Camera.look_at((3.0, 4.0, 5.0), (0.0, 1.0, 0.0), aspect=1.0)
    assert np.allclose(camera.position, (3.0, 4.0, 5.0), atol=1e-5)
    expected = -np.array([3.0, 3.0, 5.0]) / np.linalg.norm([3.0, 3.0, 5.0])
    assert np.allclose(camera.forward, expected, atol=1e-6)
    assert np.allclose(camera.view_projection, camera.projection @ camera.view, atol=1e-5)


@pytest.mark.parametrize("distance, pitch", [(0.0, 30.0), (-1.0, 30.0), (1.0, 0.5), (1.0, 91.0)])
def test_camera_at_distance_rejects_impossible_requests(distance, pitch):
    with pytest.raises(ValueError):
        camera_at_distance(distance, pitch, 1.0)
