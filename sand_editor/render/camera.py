"""Cameras: view and projection matrices (row-major maths, ``clip = P @ V @ [x, y, z, 1]``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

GroundHeight = Callable[[float, float], float]


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: world → eye (``view``) and eye → clip (``projection``), float32 (4, 4).

    ``eye`` optionally keeps the eye position in float64: float32 can place an eye 40 m from the
    world origin only to a few micrometres, too coarse for a camera a millimetre from the sand.
    """

    view: np.ndarray
    projection: np.ndarray
    eye: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("view", "projection"):
            matrix = np.asarray(getattr(self, name), dtype=np.float32)
            if matrix.shape != (4, 4):
                raise ValueError(f"Camera.{name} must be a (4, 4) matrix, got {matrix.shape}")
            object.__setattr__(self, name, matrix)
        if self.eye is None:
            object.__setattr__(self, "eye", _eye_of(self.view))
        object.__setattr__(self, "eye", np.asarray(self.eye, dtype=np.float64).reshape(3))

    @property
    def position(self) -> np.ndarray:
        """The eye in world space, (3,) float32."""
        return self.eye.astype(np.float32)

    def view_relative_to(self, origin) -> np.ndarray:
        """float64 view matrix for coordinates relative to ``origin``: what a renderer uses with
        vertices stored as offsets from a nearby origin."""
        view = self.view.astype(np.float64)
        view[:3, 3] = -view[:3, :3] @ (self.eye - np.asarray(origin, dtype=np.float64))
        return view

    @property
    def forward(self) -> np.ndarray:
        """Unit world direction of the view ray through the screen centre."""
        return (-self.view[2, :3].astype(np.float64)).astype(np.float32)

    @property
    def view_projection(self) -> np.ndarray:
        return (self.projection.astype(np.float64) @ self.view.astype(np.float64)).astype(
            np.float32
        )

    def shifted(self, pixels_x: float, pixels_y: float, size: tuple[int, int]) -> Camera:
        """The camera whose image of a ``size`` frame is this one's moved by the given pixels
        (right, up): each pixel then sees the point that lay that far left and down of its
        centre. A shift in clip space after the projection; the frustum barely changes."""
        shift = np.eye(4)
        shift[0, 3] = 2.0 * pixels_x / size[0]
        shift[1, 3] = 2.0 * pixels_y / size[1]
        projection = shift @ self.projection.astype(np.float64)
        return Camera(self.view, projection.astype(np.float32), self.eye)

    @classmethod
    def look_at(
        cls,
        eye,
        target,
        up=(0.0, 1.0, 0.0),
        fov_y_deg: float = 60.0,
        aspect: float = 16 / 9,
        near: float = 0.01,
        far: float = 5000.0,
    ) -> Camera:
        return cls(
            look_at_matrix(eye, target, up),
            perspective(fov_y_deg, aspect, near, far),
            np.asarray(eye, dtype=np.float64),
        )


def look_at_matrix(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """View matrix of an eye looking at ``target``; ``up`` may be parallel to the view ray
    (looking straight down), then world −z stands in for it."""
    eye = np.asarray(eye, dtype=np.float64)
    forward = np.asarray(target, dtype=np.float64) - eye
    length = np.linalg.norm(forward)
    if not length > 0:
        raise ValueError("look_at: eye and target coincide")
    forward /= length
    up = np.asarray(up, dtype=np.float64)
    side = np.cross(forward, up)
    if np.linalg.norm(side) < 1e-6 * np.linalg.norm(up):
        side = np.cross(forward, (0.0, 0.0, -1.0))
    side /= np.linalg.norm(side)
    true_up = np.cross(side, forward)
    view = np.identity(4)
    view[0, :3], view[1, :3], view[2, :3] = side, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    return view.astype(np.float32)


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL projection (clip z in [−w, w])."""
    if not 0 < near < far:
        raise ValueError(f"perspective: need 0 < near < far, got near={near}, far={far}")
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2)
    projection = np.zeros((4, 4))
    projection[0, 0] = f / aspect
    projection[1, 1] = f
    projection[2, 2] = (far + near) / (near - far)
    projection[2, 3] = 2 * far * near / (near - far)
    projection[3, 2] = -1.0
    return projection.astype(np.float32)


def camera_at_distance(
    distance_m: float,
    pitch_deg: float,
    aspect: float,
    ground_height: GroundHeight = lambda x, z: 0.0,
    target_xz=(0.0, 0.0),
    fov_y_deg: float = 60.0,
    heading_deg: float = 0.0,
) -> Camera:
    """A camera whose central view ray meets the ground at ``target_xz`` after ``distance_m``
    metres, looking down at ``pitch_deg`` (1°–90°) towards ``heading_deg`` (0° = north, −z;
    90° = east, +x).

    The near plane follows the distance, so depth precision holds from a millimetre to a
    kilometre, and stays in front of the target.
    """
    if not distance_m > 0 or not math.isfinite(distance_m):
        raise ValueError(f"distance_m must be a positive finite number, got {distance_m}")
    if not 1.0 <= pitch_deg <= 90.0:
        raise ValueError(f"pitch_deg must lie in 1°–90°, got {pitch_deg}")
    tx, tz = (float(v) for v in target_xz)
    target = np.array([tx, float(ground_height(tx, tz)), tz])
    pitch, heading = math.radians(pitch_deg), math.radians(heading_deg)
    # Direction of view, from the eye down to the target.
    forward = np.array(
        [
            math.cos(pitch) * math.sin(heading),
            -math.sin(pitch),
            -math.cos(pitch) * math.cos(heading),
        ]
    )
    eye = target - distance_m * forward
    # Looking straight down, "up" on screen is the heading direction.
    up = (math.sin(heading), 0.0, -math.cos(heading)) if pitch_deg > 89.9 else (0.0, 1.0, 0.0)
    near = min(max(1e-4, 0.05 * distance_m), 0.5 * distance_m)
    far = max(5000.0, 100.0 * distance_m)
    return Camera(look_at_matrix(eye, target, up), perspective(fov_y_deg, aspect, near, far), eye)


def _eye_of(view: np.ndarray) -> np.ndarray:
    """Eye position, float64: the view matrix is a rigid motion, so its inverse is the
    transposed rotation, and this avoids a general 4×4 inverse losing digits."""
    rotation = view[:3, :3].astype(np.float64)
    return -rotation.T @ view[:3, 3].astype(np.float64)
