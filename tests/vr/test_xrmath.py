"""Eye poses and fields of view → view and projection matrices."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sand_editor.render.camera import look_at_matrix, perspective
from sand_editor.vr.xrmath import (
    Fov,
    Pose,
    eye_camera,
    projection_matrix,
    quaternion_product,
    view_matrix,
)


def _yaw(angle: float) -> tuple[float, float, float, float]:
    return (0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2))


def _to_eye(view: np.ndarray, point) -> np.ndarray:
    return (view @ np.array([*point, 1.0]))[:3]


def test_identity_pose_looks_down_minus_z():
    view = view_matrix(Pose((0.0, 1.6, 0.0)))
    ahead = _to_eye(view, (0.0, 1.6, -2.0))
    np.testing.assert_allclose(ahead, (0.0, 0.0, -2.0), atol=1e-12)


def test_yaw_left_keeps_a_point_on_the_left_ahead():
    # Turned 90° to the left (counter-clockwise seen from above), −x is ahead.
    view = view_matrix(Pose((0.0, 0.0, 0.0), _yaw(math.pi / 2)))
    np.testing.assert_allclose(_to_eye(view, (-3.0, 0.0, 0.0)), (0.0, 0.0, -3.0), atol=1e-12)
    np.testing.assert_allclose(_to_eye(view, (0.0, 0.0, -1.0)), (1.0, 0.0, 0.0), atol=1e-12)


def test_view_is_the_inverse_of_the_pose_and_matches_look_at():
    pose = Pose(
        (1.0, 2.0, 3.0), quaternion_product(_yaw(0.7), (math.sin(-0.2), 0, 0, math.cos(-0.2)))
    )
    np.testing.assert_allclose(view_matrix(pose) @ pose.matrix(), np.identity(4), atol=1e-12)
    target = np.array(pose.position) + pose.forward
    np.testing.assert_allclose(view_matrix(pose), look_at_matrix(pose.position, target), atol=1e-6)


def test_unnormalised_and_zero_quaternions_give_rotations():
    for q in [(0.0, 2.0, 0.0, 2.0), (0.0, 0.0, 0.0, 0.0), (float("nan"), 0, 0, 1)]:
        rotation = Pose((0, 0, 0), q).rotation()
        assert np.all(np.isfinite(rotation))
        np.testing.assert_allclose(rotation @ rotation.T, np.identity(3), atol=1e-12)


def test_symmetric_fov_matches_perspective():
    fov = Fov.symmetric(math.radians(60.0), 1.5)
    np.testing.assert_allclose(
        projection_matrix(fov, 0.1, 100.0), perspective(60.0, 1.5, 0.1, 100.0), rtol=1e-6
    )


def test_asymmetric_fov_maps_its_edges_to_the_clip_edges():
    fov = Fov(-0.9, 0.6, 0.8, -0.7)
    p = projection_matrix(fov, 0.01, 1000.0)
    for angle_x, angle_y, expected in [
        (fov.angle_left, 0.0, (-1.0, None)),
        (fov.angle_right, 0.0, (1.0, None)),
        (0.0, fov.angle_up, (None, 1.0)),
        (0.0, fov.angle_down, (None, -1.0)),
    ]:
        point = np.array([math.tan(angle_x) * 5, math.tan(angle_y) * 5, -5.0, 1.0])
        clip = p @ point
        ndc = clip[:3] / clip[3]
        if expected[0] is not None:
            assert ndc[0] == pytest.approx(expected[0])
        if expected[1] is not None:
            assert ndc[1] == pytest.approx(expected[1])
        assert -1.0 < ndc[2] < 1.0


@pytest.mark.parametrize("near,far", [(1e-3, 1e4), (0.005, 20000.0)])
def test_depth_runs_from_minus_one_at_near_to_one_at_far(near, far):
    p = projection_matrix(Fov(-0.7, 0.7, 0.7, -0.7), near, far)
    for z, expected in [(-near, -1.0), (-far, 1.0)]:
        clip = p @ np.array([0.0, 0.0, z, 1.0])
        assert clip[2] / clip[3] == pytest.approx(expected, abs=1e-6)


def test_bad_frustums_are_refused():
    with pytest.raises(ValueError, match="near"):
        projection_matrix(Fov(-0.5, 0.5, 0.5, -0.5), 1.0, 0.5)
    with pytest.raises(ValueError, match="empty field of view"):
        projection_matrix(Fov(0.5, -0.5, 0.5, -0.5), 0.1, 10.0)


def test_two_eyes_a_millimetre_from_sand_far_from_the_origin_keep_their_separation():
    fov = Fov(-0.74, 0.74, 0.78, -0.78)
    left = eye_camera(Pose((40_000.0 - 0.0315, 1.0, 0.0)), fov, 0.001, 1e4)
    right = eye_camera(Pose((40_000.0 + 0.0315, 1.0, 0.0)), fov, 0.001, 1e4)
    assert right.eye[0] - left.eye[0] == pytest.approx(0.063, abs=1e-9)
    relative = right.view_relative_to(right.eye) - left.view_relative_to(left.eye)
    assert np.all(np.isfinite(relative))
