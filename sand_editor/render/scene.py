"""What the renderer draws, and at which level of detail: the dune terrain's rings centred below
the eye, the sand sphere beside the view, fixed sand-covered objects, and casters (objects
someone else draws, such as the workbench's desk, that cast shadows on the sand).

``SceneMeshes.prepare_frame`` chooses one frame's meshes from the head; every eye of the frame
draws what it chose. Each mesh has a ``serial`` that names it for good (a rebuilt mesh is another
one), so the shadow maps know when what casts into them has changed.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import moderngl
import numpy as np

from sand_editor.render.camera import Camera
from sand_editor.render.terrain import DuneTerrain, sphere_mesh

TERRAIN_SEGMENTS = 96
_VERTEX_FORMAT = "3f 3f 3f 2f"
_VERTEX_ATTRIBUTES = ("a_position", "a_normal", "a_tangent", "a_uv")
_POSITION_FORMAT = "3f 8x4"  # the shadow casters read the position alone
_SERIALS = itertools.count()


class SandMesh:
    """Vertex arrays of a mesh dict (``position`` relative to ``origin``), one per surface
    program and one of positions for the shadow maps. ``top`` is its highest point (world y);
    ``indices`` the length of its index buffer."""

    def __init__(self, ctx: moderngl.Context, programs, depth_program, mesh: dict, origin) -> None:
        vertices = np.hstack([mesh["position"], mesh["normal"], mesh["tangent"], mesh["uv"]])
        self.origin = np.asarray(origin, dtype=np.float64)
        self.serial = next(_SERIALS)
        self.top = float(self.origin[1] + np.max(mesh["position"][:, 1]))
        # A mesh of rings (the terrain's): their radii about ring_center, so that a shadow map
        # draws only the rings that can cast into it.
        self.rings = mesh.get("rings")
        self.no_ripples = 0.0 if mesh.get("ripples") else 1.0  # wind ripples: the dunes only
        self.ring_center = mesh.get("ring_center")
        if self.rings is not None:
            # Each band's lowest and highest point (world y): between two rings of vertices.
            heights = mesh["position"][:, 1].reshape(len(self.rings), -1) + self.origin[1]
            low, high = heights.min(axis=1), heights.max(axis=1)
            self._band_heights = (np.minimum(low[:-1], low[1:]), np.maximum(high[:-1], high[1:]))
        # World corners of an object's box (None for the ground, which reaches the horizon).
        self.bounds = None if self.rings is not None else _bounds(mesh["position"], self.origin)
        self.buffer = ctx.buffer(vertices.astype(np.float32).tobytes())
        self.index = ctx.buffer(mesh["index"].astype(np.uint32).tobytes())

        def vao(prog, layout):
            buffers = [(self.buffer, *layout)]
            return ctx.vertex_array(prog, buffers, index_buffer=self.index, index_element_size=4)

        self.vaos = [vao(prog, (_VERTEX_FORMAT, *_VERTEX_ATTRIBUTES)) for prog in programs]
        self.depth_vao = vao(depth_program, (_POSITION_FORMAT, "a_position"))
        self.indices = len(mesh["index"])
        self.triangles = self.indices // 3

    def ring_ranges(self, eye, distance_m: float):
        """For a mesh of rings (triangles ring after ring), the (first index, count) runs of
        the rings that come within ``distance_m`` of ``eye`` and of those that reach beyond
        it."""
        rings = self.rings
        per_band = self.indices // (len(rings) - 1)
        eye = np.asarray(eye, dtype=np.float64)
        off = math.hypot(eye[0] - self.ring_center[0], eye[2] - self.ring_center[1])
        # Band k spans radii rings[k]..rings[k+1]: its nearest point is at least
        # rings[k] − off away, its farthest at most √((rings[k+1] + off)² + vertical²).
        near_bands = int(np.searchsorted(rings[:-1], distance_m + off, side="right"))
        low, high = self._band_heights
        vertical = np.maximum(np.abs(eye[1] - low), np.abs(eye[1] - high))
        beyond = np.flatnonzero(np.hypot(rings[1:] + off, vertical) > distance_m)
        first_far = int(beyond[0]) if beyond.size else len(rings) - 1
        bands = len(rings) - 1
        return (0, near_bands * per_band), (first_far * per_band, (bands - first_far) * per_band)

    def release(self) -> None:
        for obj in (*self.vaos, self.depth_vao, self.buffer, self.index):
            obj.release()


class CasterMesh:
    """Triangles that only cast shadows here (another program draws them): ``triangles`` (n, 3)
    world positions, three per triangle, kept relative to ``origin``."""

    rings = None

    def __init__(self, ctx: moderngl.Context, depth_program, triangles, origin) -> None:
        self.origin = np.asarray(origin, dtype=np.float64)
        relative = np.asarray(triangles, dtype=np.float64).reshape(-1, 3) - self.origin
        if len(relative) < 3 or len(relative) % 3:
            raise ValueError(f"casters come as whole triangles, not {len(relative)} vertices")
        self.serial = next(_SERIALS)
        self.top = float(self.origin[1] + relative[:, 1].max())
        self.indices = len(relative)  # vertices drawn, three per triangle
        self.bounds = _bounds(relative, self.origin)
        self.buffer = ctx.buffer(relative.astype(np.float32).tobytes())
        self.depth_vao = ctx.vertex_array(depth_program, [(self.buffer, "3f", "a_position")])

    def release(self) -> None:
        self.depth_vao.release()
        self.buffer.release()


@dataclass(frozen=True)
class FrameScene:
    """What one frame draws in the sand material, chosen once from the head: the terrain's
    level of detail, the sphere and the fixed objects, and what else casts shadows. Every eye
    of the frame draws the same meshes, so two eyes never disagree and nothing is rebuilt
    between them."""

    terrain: SandMesh
    objects: tuple[SandMesh, ...] = ()
    head: Camera | None = None  # what the shadow maps are fitted to
    casters: tuple[CasterMesh, ...] = ()

    @property
    def shadow_casters(self) -> tuple:
        return (self.terrain, *self.objects, *self.casters)


def _bounds(positions, origin) -> np.ndarray:
    positions = np.asarray(positions, dtype=np.float64)
    return np.stack([positions.min(axis=0), positions.max(axis=0)]) + origin


class SceneMeshes:
    """The meshes of ``terrain`` and the objects on it, for the surface ``programs`` (one vertex
    array each) and the shadow maps' ``depth_program``. ``terrain_meshes_built`` counts terrain
    level-of-detail rebuilds."""

    def __init__(self, ctx: moderngl.Context, terrain: DuneTerrain, programs, depth_program):
        self.ctx = ctx
        self.terrain = terrain
        self._programs = programs
        self._depth_program = depth_program
        self._terrain_mesh: SandMesh | None = None
        self._terrain_key = None
        self._sphere_mesh: SandMesh | None = None
        self._sphere_key = None
        self._objects: list[SandMesh] = []
        self._casters: list[CasterMesh] = []
        self.terrain_meshes_built = 0

    def add_object(self, mesh: dict, origin) -> None:
        self._objects.append(self._mesh(mesh, origin))

    def add_caster(self, triangles, origin) -> None:
        self._casters.append(CasterMesh(self.ctx, self._depth_program, triangles, origin))

    def clear_objects(self) -> None:
        for kept in (self._objects, self._casters):
            while kept:
                kept.pop().release()

    def prepare_frame(self, head: Camera, show_sphere: bool) -> FrameScene:
        objects = list(self._objects)
        if show_sphere:
            sphere = self._sphere(head)
            if sphere is not None:
                objects.append(sphere)
        return FrameScene(self._terrain(head.eye), tuple(objects), head, tuple(self._casters))

    def terrain_level_of_detail(self, eye, ground: float | None = None) -> tuple:
        """(finest ring spacing, centre, outer radius) of the terrain mesh for an eye (``ground``:
        the height below it, if known): rebuilt only when this changes, as the eye moves by a
        fraction of the finest spacing or its height above the ground changes by a factor 2."""
        below = self.terrain.height(eye[0], eye[2]) if ground is None else ground
        clearance = max(float(eye[1]) - float(below), 1e-6)
        inner = 2.0 ** math.floor(math.log2(min(max(0.1 * clearance, 1e-6), 0.5)))
        snap = 2.0 * inner
        center = (round(eye[0] / snap) * snap, round(eye[2] / snap) * snap)
        # High above the dunes the horizon lies far away: the desert reaches it.
        outer = max(self.terrain.extent_m, 2.0 ** math.ceil(math.log2(50.0 * clearance)))
        return (inner, center, outer)

    def _terrain(self, eye: np.ndarray) -> SandMesh:
        """Rings centred below the eye, finest where the eye is closest to the ground."""
        key = self.terrain_level_of_detail(eye)
        inner, center, outer = key
        if key != self._terrain_key:
            origin = np.array([center[0], float(self.terrain.height(*center)), center[1]])
            mesh = self.terrain.radial_mesh(center, inner, outer, TERRAIN_SEGMENTS, origin=origin)
            if self._terrain_mesh is not None:
                self._terrain_mesh.release()
            self._terrain_mesh = self._mesh(mesh, origin)
            self._terrain_key = key
            self.terrain_meshes_built += 1
        return self._terrain_mesh

    def _sphere(self, camera: Camera) -> SandMesh | None:
        """The sphere of ``DuneTerrain.sphere_beside_view``, rebuilt only when it moves."""
        placed = self.terrain.sphere_beside_view(camera.eye, camera.forward)
        if placed is None:
            return None
        center, radius = placed
        key = tuple(np.round(center / max(radius * 1e-3, 1e-9)).astype(np.int64)) + (radius,)
        if key != self._sphere_key:
            mesh = sphere_mesh(center, radius, 32, origin=center)
            if self._sphere_mesh is not None:
                self._sphere_mesh.release()
            self._sphere_mesh = self._mesh(mesh, center)
            self._sphere_key = key
        return self._sphere_mesh

    def _mesh(self, mesh: dict, origin) -> SandMesh:
        return SandMesh(self.ctx, self._programs, self._depth_program, mesh, origin)

    def release(self) -> None:
        self.clear_objects()
        for mesh in (self._terrain_mesh, self._sphere_mesh):
            if mesh is not None:
                mesh.release()
        self._terrain_mesh = self._sphere_mesh = None
        self._terrain_key = self._sphere_key = None
