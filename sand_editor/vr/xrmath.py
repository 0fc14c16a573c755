"""Poses and fields of view as OpenXR gives them, turned into the renderer's matrices.

Row-major maths as in ``sand_editor.render.camera`` (``clip = P @ V @ [x, y, z, 1]``); OpenXR's
conventions: right-handed, y up, a view looks along its −z; quaternions are (x, y, z, w).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sand_editor.render.camera import Camera

# The eyes' clip planes (the compositor is told them with the depth it is given).
NEAR_M = 0.005  # a few millimetres: the sand can be inspected from that close
FAR_M = 20000.0


@dataclass(frozen=True)
class Pose:
    """A rigid placement: ``position`` (3,) metres and unit quaternion ``orientation`` (x, y, z,
    w), both float64."""

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)

    def rotation(self) -> np.ndarray:
        """(3, 3) rotation matrix; the quaternion is normalised first (runtimes send them only
        nearly unit), and a zero quaternion counts as no rotation."""
        x, y, z, w = (float(c) for c in self.orientation)
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        if not norm > 1e-12 or not math.isfinite(norm):
            return np.identity(3)
        x, y, z, w = x / norm, y / norm, z / norm, w / norm
        return np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )

    def matrix(self) -> np.ndarray:
        """(4, 4) local → world transform."""
        m = np.identity(4)
        m[:3, :3] = self.rotation()
        m[:3, 3] = self.position
        return m

    @property
    def forward(self) -> np.ndarray:
        """Unit world direction of the pose's −z axis (where a view or an aim ray points)."""
        return -self.rotation()[:, 2]

    def translated(self, offset) -> Pose:
        moved = tuple(float(a + b) for a, b in zip(self.position, offset, strict=True))
        return Pose(moved, self.orientation)

    @classmethod
    def from_yaw_pitch(cls, position, yaw_rad: float, pitch_rad: float) -> Pose:
        """Looking towards heading ``yaw_rad`` (0 = −z, positive turns left, towards −x) and
        ``pitch_rad`` above the horizon."""
        qy = (0.0, math.sin(yaw_rad / 2), 0.0, math.cos(yaw_rad / 2))
        qx = (math.sin(pitch_rad / 2), 0.0, 0.0, math.cos(pitch_rad / 2))
        return cls(tuple(float(v) for v in position), quaternion_product(qy, qx))


def quaternion_product(a, b) -> tuple[float, float, float, float]:
    """``a ⊗ b`` for (x, y, z, w) quaternions: rotate by ``b``, then by ``a``."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


@dataclass(frozen=True)
class Fov:
    """Angles of an eye's view frustum in radians: left and down negative, right and up
    positive for a view that looks straight ahead (as ``XrFovf``)."""

    angle_left: float
    angle_right: float
    angle_up: float
    angle_down: float

    def as_dict(self) -> dict[str, float]:
        return {
            "angle_left": self.angle_left,
            "angle_right": self.angle_right,
            "angle_up": self.angle_up,
            "angle_down": self.angle_down,
        }

    @classmethod
    def symmetric(cls, fov_y_rad: float, aspect: float) -> Fov:
        half_y = fov_y_rad / 2
        half_x = math.atan(math.tan(half_y) * aspect)
        return cls(-half_x, half_x, half_y, -half_y)


def view_matrix(pose: Pose) -> np.ndarray:
    """World → eye: the inverse of the eye's rigid pose (transposed rotation)."""
    rotation = pose.rotation()
    view = np.identity(4)
    view[:3, :3] = rotation.T
    view[:3, 3] = -rotation.T @ np.asarray(pose.position, dtype=np.float64)
    return view


def projection_matrix(fov: Fov, near: float, far: float) -> np.ndarray:
    """OpenGL projection (clip z in [−w, w]) of an asymmetric frustum."""
    if not 0 < near < far:
        raise ValueError(f"projection: need 0 < near < far, got near={near}, far={far}")
    left, right = math.tan(fov.angle_left), math.tan(fov.angle_right)
    up, down = math.tan(fov.angle_up), math.tan(fov.angle_down)
    if not (right > left and up > down):
        raise ValueError(f"projection: empty field of view {fov}")
    p = np.zeros((4, 4))
    p[0, 0] = 2 / (right - left)
    p[0, 2] = (right + left) / (right - left)
    p[1, 1] = 2 / (up - down)
    p[1, 2] = (up + down) / (up - down)
    p[2, 2] = -(far + near) / (far - near)
    p[2, 3] = -2 * far * near / (far - near)
    p[3, 2] = -1.0
    return p


def eye_camera(pose: Pose, fov: Fov, near: float, far: float) -> Camera:
    """The renderer's camera for one eye (its float64 position kept exact)."""
    return Camera(
        view_matrix(pose),
        projection_matrix(fov, near, far),
        np.asarray(pose.position, dtype=np.float64),
    )
