"""The workbench's shapes: boxes with per-face texture mapping (any of them may be turned about
the vertical), the desk with its tray of sand, and the controllers' bodies.

Sand meshes are dicts as the renderer takes them (``position`` relative to an origin,
``normal``, ``tangent``, ``uv`` in metres along each face, ``index``); the desk, the tray's
walls and the controllers are drawn in plain colours (``props``): (n, 9) float32 rows of
position, normal and linear albedo, three rows per triangle.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sand_editor.render.terrain import sphere_mesh

DESK_HEIGHT_M = 0.78  # top of the desk above the ground under its middle
DESK_SIZE_M = (1.0, 0.04, 0.6)  # width (x), thickness, depth (z)
DESK_DISTANCE_M = 0.55  # from the standing point to the desk's middle, straight ahead
LEG_SIZE_M = 0.05
LEG_INSET_M = 0.06
TRAY_INNER_M = (0.52, 0.34)  # the sand's width and depth
TRAY_WALL_M = (0.025, 0.05)  # thickness, height above the desk
TRAY_OFFSET_M = (-0.12, 0.04)  # the tray's middle from the desk's (x, z)
SAND_BELOW_RIM_M = 0.012
SPHERE_RADIUS_M = 0.07
SPHERE_OFFSET_M = (0.32, 0.08)  # on the desk, right of the tray (x, z from the desk's middle)

WOOD = (0.3, 0.17, 0.08)
DARK_WOOD = (0.12, 0.07, 0.035)
STEEL = (0.32, 0.33, 0.35)
CONTROLLER = (0.06, 0.06, 0.07)
CONTROLLER_RING = (0.55, 0.56, 0.6)

# Faces of a box: outward normal, and the tangent along which u runs.
_FACES = (
    ((0, 1, 0), (1, 0, 0)),
    ((0, -1, 0), (1, 0, 0)),
    ((1, 0, 0), (0, 0, -1)),
    ((-1, 0, 0), (0, 0, 1)),
    ((0, 0, 1), (1, 0, 0)),
    ((0, 0, -1), (-1, 0, 0)),
)
_CORNERS = ((-1, -1), (1, -1), (1, 1), (-1, 1))
_QUAD_TRIANGLES = (0, 2, 1, 0, 3, 2)  # counter-clockwise seen from outside


def yaw_rotation(yaw: float) -> np.ndarray:
    """(3, 3) turn by ``yaw`` radians about +y (positive to the left, as ``TrackingOrigin``)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def box_mesh(center, size, origin=None, rotation=None) -> dict:
    """A box of ``size`` (along its own x, y, z) at ``center``, turned by ``rotation`` (3, 3;
    none: axis-aligned). Each face has its own normal and tangent and ``uv`` in metres along
    the face, measured in the box's own frame, so the sand's grains lie flat on every face at
    their true size (same handedness as the terrain: cross(tangent, normal) is +v)."""
    center = np.asarray(center, dtype=np.float64)
    half = np.asarray(size, dtype=np.float64) / 2
    rotation = np.identity(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    positions, normals, tangents, uvs, indices = [], [], [], [], []
    for normal, tangent in _FACES:
        n, t = np.array(normal, float), np.array(tangent, float)
        b = np.cross(t, n)
        base = len(positions)
        for su, sv in _CORNERS:
            local = n * half + su * t * half + sv * b * half
            positions.append(center + rotation @ local)
            normals.append(rotation @ n)
            tangents.append(rotation @ t)
            uvs.append((float(np.dot(local, t)), float(np.dot(local, b))))
        indices.extend(base + i for i in _QUAD_TRIANGLES)
    position = np.array(positions)
    if origin is not None:
        position = position - np.asarray(origin, dtype=np.float64)
    return {
        "position": position.astype(np.float32),
        "normal": np.array(normals, np.float32),
        "tangent": np.array(tangents, np.float32),
        "uv": np.array(uvs, np.float32),
        "index": np.array(indices, np.uint32),
    }


def box_props(center, size, albedo, rotation=None) -> np.ndarray:
    """A plain-coloured box as ``props`` rows (world positions)."""
    mesh = box_mesh(center, size, rotation=rotation)
    index = mesh["index"]
    colour = np.broadcast_to(np.asarray(albedo, np.float32), (len(index), 3))
    return np.hstack([mesh["position"][index], mesh["normal"][index], colour])


def sand_sphere(center, radius: float, rotation=None) -> dict:
    """A sand sphere lying on its side: its poles, where a UV sphere's texture pinches, face
    left and right, and the top the user looks down on lies on its equator."""
    rotation = np.identity(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    turn = rotation @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    mesh = sphere_mesh((0.0, 0.0, 0.0), radius, 48)
    for name in ("position", "normal", "tangent"):
        mesh[name] = (mesh[name].astype(np.float64) @ turn.T).astype(np.float32)
    return mesh


class DeskLayout:
    """Where the desk, its tray, the sand and the sphere stand for a user at ``stand_xz``
    facing ``yaw``, on ground ``ground_height(x, z)``."""

    def __init__(self, ground_height, stand_xz=(0.0, 0.0), yaw: float = 0.0) -> None:
        self.rotation = yaw_rotation(yaw)
        self.stand = np.array([stand_xz[0], 0.0, stand_xz[1]], dtype=np.float64)
        middle = self.world(0.0, -DESK_DISTANCE_M)
        self.ground = float(ground_height(middle[0], middle[2]))
        self.top = self.ground + DESK_HEIGHT_M
        self.origin = np.array([middle[0], self.top, middle[2]])  # the desk top's middle
        self._ground_height = ground_height

    def world(self, x: float, z: float, y: float = 0.0) -> np.ndarray:
        """A point given in the bench's frame (x right, z towards the user, from the standing
        point; y absolute height) in the world."""
        p = self.stand + self.rotation @ np.array([x, 0.0, z])
        return np.array([p[0], y, p[2]])

    def on_desk(self, x: float, z: float, y: float = 0.0) -> np.ndarray:
        """A point given from the desk top's middle (x right, z towards the user, y up)."""
        return self.world(x, z - DESK_DISTANCE_M, self.top + y)

    def sand_objects(self) -> list[tuple[dict, np.ndarray]]:
        """(mesh, origin) of the sand in the tray and the sphere."""
        inner_w, inner_d = TRAY_INNER_M
        depth = TRAY_WALL_M[1] - SAND_BELOW_RIM_M
        sand_center = self.on_desk(TRAY_OFFSET_M[0], TRAY_OFFSET_M[1], depth / 2)
        sand = box_mesh(sand_center, (inner_w, depth, inner_d), sand_center, self.rotation)
        sphere_center = self.on_desk(*SPHERE_OFFSET_M, SPHERE_RADIUS_M)
        sphere = sand_sphere(sphere_center, SPHERE_RADIUS_M, self.rotation)
        return [(sand, sand_center), (sphere, sphere_center)]

    def props(self) -> np.ndarray:
        """The desk, its legs and the tray's walls as ``props`` rows."""
        r = self.rotation
        width, thickness, depth = DESK_SIZE_M
        parts = [box_props(self.on_desk(0.0, 0.0, -thickness / 2), DESK_SIZE_M, WOOD, r)]
        for sx in (-1, 1):
            for sz in (-1, 1):
                x = sx * (width / 2 - LEG_INSET_M)
                z = sz * (depth / 2 - LEG_INSET_M)
                foot = self.on_desk(x, z)
                bottom = float(self._ground_height(foot[0], foot[2])) - 0.1  # into the dune
                height = self.top - thickness - bottom
                center = self.on_desk(x, z, -thickness - height / 2)
                parts.append(box_props(center, (LEG_SIZE_M, height, LEG_SIZE_M), STEEL, r))
        inner_w, inner_d = TRAY_INNER_M
        wall, rim = TRAY_WALL_M
        tx, tz = TRAY_OFFSET_M
        for sz in (-1, 1):  # front and back walls run the tray's full width
            center = self.on_desk(tx, tz + sz * (inner_d + wall) / 2, rim / 2)
            parts.append(box_props(center, (inner_w + 2 * wall, rim, wall), DARK_WOOD, r))
        for sx in (-1, 1):
            center = self.on_desk(tx + sx * (inner_w + wall) / 2, tz, rim / 2)
            parts.append(box_props(center, (wall, rim, inner_d), DARK_WOOD, r))
        return np.vstack(parts).astype(np.float32)


@functools.cache
def _controller_body() -> np.ndarray:
    """The controller's ``props`` rows in its own aim frame: a grip behind the aim point, and a
    pale ring at its front where the ray leaves (built once; each frame only moves them)."""
    grip = box_props((0.0, -0.012, 0.07), (0.036, 0.03, 0.12), CONTROLLER)
    ring = box_props((0.0, 0.0, 0.006), (0.05, 0.05, 0.012), CONTROLLER_RING)
    body = np.vstack([grip, ring]).astype(np.float64)
    body.setflags(write=False)
    return body


def controller_props(pose) -> np.ndarray:
    """A controller's body at an aim ``pose`` (world), as ``props`` rows."""
    rotation = pose.rotation()
    body = _controller_body()
    rows = np.empty(body.shape, dtype=np.float32)
    rows[:, 0:3] = body[:, 0:3] @ rotation.T + np.asarray(pose.position, dtype=np.float64)
    rows[:, 3:6] = body[:, 3:6] @ rotation.T
    rows[:, 6:9] = body[:, 6:9]
    return rows
