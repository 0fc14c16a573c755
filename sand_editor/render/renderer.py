"""The scene renderer: sky, dune terrain (and a test sphere) in the sand material, bloom and tone
mapping, into any moderngl framebuffer. Qt-free: the editor's preview, the VR viewer and the
command line all draw through this class."""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import moderngl
import numpy as np

from sand_editor.gl import (
    GLObjects,
    drawing_into,
    program,
    render_state,
    set_matrix,
    set_uniform,
)
from sand_editor.render.camera import Camera
from sand_editor.render.exposure import EyeAdaptation, light_exposure, metered_exposure
from sand_editor.render.material import surface_defines
from sand_editor.render.modes import check_mode, mode_index
from sand_editor.render.post import DEFAULT_BLOOM_STRENGTH, PostChain
from sand_editor.render.shadows import SunShadows
from sand_editor.render.sky import SKY_GRADIENT_EXPONENT, SkyState
from sand_editor.render.terrain import DuneTerrain, sphere_mesh

DEBUG_MODES = frozenset({"blend", "normals", "mip"})
GROUND_ALBEDO = (0.45, 0.33, 0.22)  # the sky's stand-in for ground below the horizon
SUN_ANGULAR_RADIUS = math.radians(0.6)  # twice the real sun: readable on small previews
MOON_ANGULAR_RADIUS = math.radians(0.6)
TERRAIN_SEGMENTS = 96
_VERTEX_FORMAT = "3f 3f 3f 2f"
_VERTEX_ATTRIBUTES = ("a_position", "a_normal", "a_tangent", "a_uv")
_POSITION_FORMAT = "3f 8x4"  # the shadow casters read the position alone
_SERIALS = itertools.count()


class _Mesh:
    """Vertex arrays of a mesh dict (``position`` relative to ``origin``), one per surface
    program and one of positions for the shadow maps. ``serial`` names this mesh for good (a
    rebuilt mesh is another one); ``top`` is its highest point (world y); ``indices`` the
    length of its index buffer."""

    def __init__(self, ctx: moderngl.Context, programs, depth_program, mesh: dict, origin) -> None:
        vertices = np.hstack([mesh["position"], mesh["normal"], mesh["tangent"], mesh["uv"]])
        self.origin = origin
        self.serial = next(_SERIALS)
        self.top = float(origin[1] + np.max(mesh["position"][:, 1]))
        # A mesh of rings (the terrain's): their radii about ring_center, so that a shadow map
        # draws only the rings that can cast into it.
        self.rings = mesh.get("rings")
        self.no_ripples = 0.0 if mesh.get("ripples") else 1.0  # wind ripples: the dunes only
        self.ring_center = mesh.get("ring_center")
        self.buffer = ctx.buffer(vertices.astype(np.float32).tobytes())
        self.index = ctx.buffer(mesh["index"].astype(np.uint32).tobytes())

        def vao(prog, layout):
            buffers = [(self.buffer, *layout)]
            return ctx.vertex_array(prog, buffers, index_buffer=self.index, index_element_size=4)

        self.vaos = [vao(prog, (_VERTEX_FORMAT, *_VERTEX_ATTRIBUTES)) for prog in programs]
        self.depth_vao = vao(depth_program, (_POSITION_FORMAT, "a_position"))
        self.indices = len(mesh["index"])
        self.triangles = self.indices // 3

    def release(self) -> None:
        for obj in (*self.vaos, self.depth_vao, self.buffer, self.index):
            obj.release()


@dataclass(frozen=True)
class FrameScene:
    """What one frame draws in the sand material, chosen once from the head: the terrain's
    level of detail, the sphere and the fixed objects. Every eye of the frame draws the same
    meshes, so two eyes never disagree and nothing is rebuilt between them."""

    terrain: _Mesh
    objects: tuple[_Mesh, ...] = ()
    head: Camera | None = None  # what the shadow maps are fitted to


class SandRenderer:
    """Draws the desert in the sand material.

    ``show_sphere`` puts a sand-covered sphere on the ground near what the camera looks at.
    ``add_object`` adds fixed sand-covered meshes (a workbench, a box of sand).
    ``terrain_meshes_built`` counts terrain level-of-detail rebuilds.
    """

    def __init__(self, ctx: moderngl.Context, terrain: DuneTerrain | None = None) -> None:
        self.ctx = ctx
        self.terrain = terrain or DuneTerrain()
        self.material = None
        self.show_sphere = False
        self.bloom_strength = DEFAULT_BLOOM_STRENGTH
        self.post = PostChain(ctx)
        # Views that run on (the editor's, the headset's) adapt over time, as an eye does;
        # otherwise each frame takes its metered exposure at once, the same on every run.
        self.adapt_over_time = False
        self.relief = True  # grains at their depth and self-shadowed up close (sand_relief.glsl)
        self.tile_variation = True  # the grain tile laid without a repeat (tile_variation.glsl)
        self.sharp_ripples = True  # ripples filtered along each pixel's footprint (sand_far.glsl)
        self.shadows = True  # the sun and the moon cast shadows (render/shadows.py)
        self.adaptation = EyeAdaptation()
        self._last_metered: float | None = None
        # The surface is drawn by two variants of its program (sand_surface.glsl): the near one
        # shades what lies within the material's close range, the far one only the far term.
        self._owned = GLObjects()
        keep = self._owned.keep
        self._surface = keep(program(ctx, "terrain.glsl", surface_defines()))
        self._surface_far = keep(program(ctx, "terrain.glsl", surface_defines(SAND_FAR_ONLY=1)))
        self._surfaces = (self._surface, self._surface_far)
        self._sky = keep(program(ctx, "sky.glsl"))
        self._sky_vao = keep(ctx.vertex_array(self._sky, []))
        self._shadows = keep(SunShadows(ctx))
        self._shadow_frame = None
        self._shadow_scene = None  # (scene, sky) the shadow frame was made for
        self._terrain_mesh: _Mesh | None = None
        self._terrain_key = None
        self._sphere_mesh: _Mesh | None = None
        self._sphere_key = None
        self._fixed_objects: list[_Mesh] = []
        self._readback: moderngl.Framebuffer | None = None
        self.terrain_meshes_built = 0

    def set_material(self, material) -> None:
        """The ``SandMaterial`` (anything with ``bind(program, first_unit) -> int``)."""
        self.material = material

    def add_object(self, mesh: dict, origin) -> None:
        """A fixed object in the sand material: ``mesh`` as ``terrain.sphere_mesh`` makes it,
        positions relative to ``origin`` (world, float64)."""
        origin = np.asarray(origin, dtype=np.float64)
        self._fixed_objects.append(self._mesh(mesh, origin))

    def clear_objects(self) -> None:
        """Remove (and release) every fixed object."""
        while self._fixed_objects:
            self._fixed_objects.pop().release()

    # ---- frame ------------------------------------------------------------------------------

    def prepare_frame(self, head: Camera, show_sphere: bool | None = None) -> FrameScene:
        """The scene objects for one frame seen from ``head`` (for stereo, the point between
        the eyes looking where the head looks); pass it to ``render`` for every eye. It holds
        until the next ``prepare_frame``, which may replace the meshes it names."""
        objects = list(self._fixed_objects)
        if self.show_sphere if show_sphere is None else show_sphere:
            sphere = self._sphere(head)
            if sphere is not None:
                objects.append(sphere)
        return FrameScene(self._terrain(head.eye), tuple(objects), head)

    def render(
        self,
        target: moderngl.Framebuffer,
        camera: Camera,
        sky: SkyState,
        mode: str = "full",
        viewport: tuple[int, int, int, int] | None = None,
        exposure: float | None = None,
        show_sphere: bool | None = None,
        scene: FrameScene | None = None,
        extra=None,
        depth_out: bool = False,
    ) -> dict:
        """Draw one frame into ``viewport`` of ``target`` (its whole area by default).

        ``scene`` is what ``prepare_frame`` chose for this frame; without it the scene is chosen
        from ``camera`` (one view, as in the editor). Debug modes (``blend``, ``normals``,
        ``mip``) write the material's values unexposed and unblended, over black. Without
        ``exposure`` the frame is metered (and with ``adapt_over_time`` the eye's adaptation
        follows it, the first frame jumping to it); a number fixes it. ``extra(camera, sky)``
        draws more (not sand) into the scene, depth-tested, before it is exposed; with
        ``depth_out`` the scene's depth goes into the target's depth buffer too. Returns CPU
        milliseconds per stage and the exposure used.
        """
        check_mode(mode)
        debug = mode in DEBUG_MODES
        viewport = tuple(int(v) for v in (viewport or (0, 0, *target.size)))
        ctx = self.ctx
        times = {}
        start = time.perf_counter()
        self.post.resize(viewport[2], viewport[3])
        if scene is None:
            scene = self.prepare_frame(camera, show_sphere)
        hdr_target = self.post.scene_framebuffer
        self._shadow_frame = self._shadow_maps(scene, camera, sky, debug, viewport[2:])
        times["shadows_ms"] = _lap(start)

        with drawing_into(ctx, hdr_target):
            ctx.viewport = (0, 0, *self.post.size)
            hdr_target.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            if not debug:
                self._draw_sky(camera, sky)
            times["sky_ms"] = _lap(start) - times["shadows_ms"]
            with render_state(ctx, moderngl.DEPTH_TEST):
                self._prepare_surface(camera, sky, mode)
                for mesh in (scene.terrain, *scene.objects):
                    self._draw(mesh, camera)
                if extra is not None:
                    extra(camera, sky)
            times["surface_ms"] = _lap(start) - times["shadows_ms"] - times["sky_ms"]
        if exposure is None:
            # Metered from this frame's scene and adapted over time, as an eye does.
            now = time.perf_counter()
            last, self._last_metered = self._last_metered, now
            dt = now - last if self.adapt_over_time and last is not None else None

            def exposure(scene_luminance: float) -> float:
                if debug or mode == "glints":  # glints alone would meter as a black scene
                    return light_exposure(sky)
                return self.adaptation.step(metered_exposure(sky, scene_luminance), dt)

        exposure = self.post.finish(
            target,
            viewport,
            exposure,
            bloom_strength=0.0 if debug else self.bloom_strength,
            tone_map=not debug,
        )
        if depth_out:
            self.post.copy_depth(target, viewport)
        drawn = ("shadows_ms", "sky_ms", "surface_ms")
        times["post_ms"] = _lap(start) - sum(times[k] for k in drawn)
        times["exposure"] = exposure
        return times

    def render_to_array(
        self, width: int, height: int, camera: Camera, sky: SkyState, mode: str = "full", **options
    ) -> np.ndarray:
        """The frame as an (height, width, 3) uint8 array, rows top-down."""
        if self._readback is None or self._readback.size != (width, height):
            self._release_readback()
            texture = self.ctx.texture((width, height), 4)
            self._readback = self.ctx.framebuffer([texture])
        self.render(self._readback, camera, sky, mode, **options)
        data = self._readback.read(components=3, alignment=1)
        image = np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3)
        return image[::-1].copy()

    # ---- passes -----------------------------------------------------------------------------

    def _draw_sky(self, camera: Camera, sky: SkyState) -> None:
        rotation_only = camera.view.astype(np.float64).copy()
        rotation_only[:3, 3] = 0.0
        inverse = np.linalg.inv(camera.projection.astype(np.float64) @ rotation_only)
        prog = self._sky
        set_matrix(prog, "u_inverse_view_projection", inverse)
        values = {
            "u_resolution": tuple(float(v) for v in self.post.size),
            "u_sun_direction": _vec(sky.sun_direction),
            "u_sun_radiance": _vec(sky.sun_radiance),
            "u_moon_direction": _vec(sky.moon_direction),
            "u_moon_radiance": _vec(sky.moon_radiance),
            "u_sky_zenith": _vec(sky.sky_zenith),
            "u_sky_horizon": _vec(sky.sky_horizon),
            "u_sky_irradiance": _vec(sky.sky_irradiance),
            "u_ground_albedo": GROUND_ALBEDO,
            "u_star_visibility": float(sky.star_visibility),
            "u_gradient_exponent": SKY_GRADIENT_EXPONENT,
            "u_sun_radius": SUN_ANGULAR_RADIUS,
            "u_moon_radius": MOON_ANGULAR_RADIUS,
        }
        for name, value in values.items():
            set_uniform(prog, name, value)
        with render_state(self.ctx):
            self._sky_vao.render(moderngl.TRIANGLES, vertices=3)

    def _shadow_maps(self, scene: FrameScene, camera: Camera, sky: SkyState, debug: bool, size):
        """The frame's shadow maps (drawn once for the frame's head; None when off)."""
        if not self.shadows or debug:
            self._shadow_scene = None
            return None
        if self._shadow_scene is not None and all(
            a is b for a, b in zip(self._shadow_scene, (scene, sky), strict=True)
        ):
            return self._shadow_frame  # the frame's other eye: the same maps
        self._shadow_scene = (scene, sky)
        head = scene.head or camera
        meshes = (scene.terrain, *scene.objects)
        # Anything in the scene stands at most this far above the lowest ground in view.
        rise = max(mesh.top for mesh in meshes) + self.terrain.height_bound
        clearance = self.terrain.clearance(head.eye)
        return self._shadows.update(meshes, head, sky, clearance, rise, size)

    @property
    def shadow_maps_drawn(self) -> int:
        """How many frames drew their shadow maps (the others kept the last ones)."""
        return self._shadows.maps_drawn

    def _prepare_surface(self, camera: Camera, sky: SkyState, mode: str) -> None:
        for prog in self._surfaces:
            self._prepare_program(prog, camera, sky, mode)

    def _prepare_program(self, prog, camera: Camera, sky: SkyState, mode: str) -> None:
        if self.material is not None:
            self.material.bind(prog, 0)
        values = {
            "u_mode": mode_index(mode),
            "u_relief": int(self.relief),
            "u_sharp_ripples": int(self.sharp_ripples),
            "u_tile_variation": int(self.tile_variation),
            "u_eye": _vec(camera.position),
            "u_sun_direction": _vec(sky.sun_direction),
            "u_sun_radiance": _vec(sky.sun_radiance),
            "u_moon_direction": _vec(sky.moon_direction),
            "u_moon_radiance": _vec(sky.moon_radiance),
            "u_sky_irradiance": _vec(sky.sky_irradiance),
        }
        for name, value in values.items():
            set_uniform(prog, name, value)
        self._shadows.bind(prog, self._shadow_frame)

    def _draw(self, mesh: _Mesh, camera: Camera) -> None:
        # Vertices are offsets from the mesh origin, and so is the eye in this matrix: small
        # numbers that keep their precision in float32 anywhere in the desert.
        view_projection = camera.projection.astype(np.float64) @ camera.view_relative_to(
            mesh.origin
        )
        self._shadows.bind_mesh(self._surfaces, self._shadow_frame, mesh.origin)
        for prog, vao in zip(self._surfaces, mesh.vaos, strict=True):
            set_matrix(prog, "u_view_projection", view_projection)
            set_uniform(prog, "u_origin", _vec(mesh.origin))
            set_uniform(prog, "u_no_ripples", mesh.no_ripples)
            vao.render(moderngl.TRIANGLES)

    # ---- meshes -----------------------------------------------------------------------------

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

    def _terrain(self, eye: np.ndarray) -> _Mesh:
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

    def _sphere(self, camera: Camera) -> _Mesh | None:
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

    def _mesh(self, mesh: dict, origin) -> _Mesh:
        return _Mesh(self.ctx, self._surfaces, self._shadows.program, mesh, origin)

    # ---- lifetime ---------------------------------------------------------------------------

    def _release_readback(self) -> None:
        if self._readback is not None:
            for texture in self._readback.color_attachments:
                texture.release()
            self._readback.release()
            self._readback = None

    def release(self) -> None:
        for mesh in (self._terrain_mesh, self._sphere_mesh, *self._fixed_objects):
            if mesh is not None:
                mesh.release()
        self._fixed_objects.clear()
        self._terrain_mesh = self._sphere_mesh = None
        self._terrain_key = self._sphere_key = None
        self._release_readback()
        self._owned.release()
        self.post.release()


def _vec(v) -> tuple[float, float, float]:
    return tuple(float(c) for c in np.asarray(v).ravel()[:3])


def _lap(start: float) -> float:
    return (time.perf_counter() - start) * 1000.0
