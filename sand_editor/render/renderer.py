"""The scene renderer: sky, dune terrain (and a test sphere) in the sand material, bloom and tone
mapping, into any moderngl framebuffer. Qt-free: the editor's preview, the VR viewer and the
command line all draw through this class."""

from __future__ import annotations

import dataclasses
import math
import time

import moderngl
import numpy as np

from sand_editor.gl import (
    GLObjects,
    drawing_into,
    finish_without_gil,
    program,
    render_state,
    set_matrix,
    set_uniform,
)
from sand_editor.render.camera import Camera
from sand_editor.render.exposure import ExposureControl
from sand_editor.render.material import surface_defines
from sand_editor.render.modes import BLENDED_MODES, mode_index
from sand_editor.render.post import DEFAULT_BLOOM_STRENGTH, PostChain
from sand_editor.render.request import FrameRequest
from sand_editor.render.scene import FrameScene, SandMesh, SceneMeshes
from sand_editor.render.shadows import SceneShadows, SunShadows
from sand_editor.render.sky import SKY_GRADIENT_EXPONENT, SkyState
from sand_editor.render.still import GatheredLight, check_samples, sample_camera
from sand_editor.render.terrain import DuneTerrain

GROUND_ALBEDO = (0.45, 0.33, 0.22)  # the sky's stand-in for ground below the horizon
SUN_ANGULAR_RADIUS = math.radians(0.6)  # twice the real sun: readable on small previews
MOON_ANGULAR_RADIUS = math.radians(0.6)
# The sky program's uniforms that never change.
SKY_CONSTANTS = {
    "u_ground_albedo": GROUND_ALBEDO,
    "u_gradient_exponent": SKY_GRADIENT_EXPONENT,
    "u_sun_radius": SUN_ANGULAR_RADIUS,
    "u_moon_radius": MOON_ANGULAR_RADIUS,
}
# What of the sky the surface programs read (sky_uniforms' names).
SURFACE_SKY = (
    "u_sun_direction", "u_sun_radiance", "u_moon_direction", "u_moon_radiance",
    "u_sky_irradiance",
)  # fmt: skip


def sky_uniforms(sky: SkyState, names=None) -> dict:
    """The sky at one moment as the sky program's uniforms (``names``: only those)."""
    values = {
        "u_sun_direction": _vec(sky.sun_direction),
        "u_sun_radiance": _vec(sky.sun_radiance),
        "u_moon_direction": _vec(sky.moon_direction),
        "u_moon_radiance": _vec(sky.moon_radiance),
        "u_sky_zenith": _vec(sky.sky_zenith),
        "u_sky_horizon": _vec(sky.sky_horizon),
        "u_sky_irradiance": _vec(sky.sky_irradiance),
        "u_star_visibility": float(sky.star_visibility),
    }
    return values if names is None else {name: values[name] for name in names}


class SandRenderer:
    """Draws the desert in the sand material.

    ``show_sphere`` puts a sand-covered sphere on the ground near what the camera looks at.
    ``add_object`` adds fixed sand-covered meshes (a workbench, a box of sand), ``add_caster``
    fixed triangles drawn by someone else that cast shadows on them (the workbench's desk).
    """

    def __init__(self, ctx: moderngl.Context, terrain: DuneTerrain | None = None) -> None:
        self.ctx = ctx
        self.terrain = terrain or DuneTerrain()
        self.material = None
        self.show_sphere = False
        self.bloom_strength = DEFAULT_BLOOM_STRENGTH
        self.post = PostChain(ctx)
        self.relief = True  # grains at their depth and self-shadowed up close (sand_relief.glsl)
        self.tile_variation = True  # the grain tile laid without a repeat (tile_variation.glsl)
        self.sharp_ripples = True  # ripples filtered along each pixel's footprint (sand_far.glsl)
        # False: each sample's ripples unfiltered, as a supersampled truth averages them (the
        # filter is what such a truth measures).
        self.filter_ripples = True
        self.anisotropic = True  # grain textures read in taps along a grazing footprint
        self.shadows = True  # the sun and the moon cast shadows (render/shadows.py)
        # Each surface variant draws only the rings it can shade (off: both draw everything,
        # which the suite compares pixel for pixel).
        self.split_ranges = True
        self.exposure = ExposureControl()
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
        self.meshes = SceneMeshes(ctx, self.terrain, self._surfaces, self._shadows.program)
        self._readback: moderngl.Framebuffer | None = None

    @property
    def wait_without_gil(self) -> bool:
        """Where a pass reads what an earlier one drew, wait for it without Python's lock: on a
        CPU rasterizer that wait is the drawing, which moderngl would otherwise do holding the
        lock, stopping every other thread (the editor draws on a thread of its own). Off by
        default: on a GPU each wait stalls the pipeline. Kept by the post chain, whose passes
        wait the same way."""
        return self.post.wait_without_gil

    @wait_without_gil.setter
    def wait_without_gil(self, on: bool) -> None:
        self.post.wait_without_gil = bool(on)

    def set_material(self, material) -> None:
        """The ``SandMaterial`` (anything with ``bind(program, first_unit) -> int``)."""
        self.material = material

    def add_object(self, mesh: dict, origin) -> None:
        """A fixed object in the sand material: ``mesh`` as ``terrain.sphere_mesh`` makes it,
        positions relative to ``origin`` (world, float64)."""
        self.meshes.add_object(mesh, origin)

    def add_caster(self, triangles, origin) -> None:
        """Fixed triangles that cast shadows and are drawn by someone else (``render``'s
        ``extra``): (n, 3) world positions, three per triangle, kept relative to ``origin``."""
        self.meshes.add_caster(triangles, origin)

    def clear_objects(self) -> None:
        """Remove (and release) every fixed object and caster."""
        self.meshes.clear_objects()

    @property
    def terrain_meshes_built(self) -> int:
        """How many times the terrain's level of detail was rebuilt."""
        return self.meshes.terrain_meshes_built

    def terrain_level_of_detail(self, eye, ground: float | None = None) -> tuple:
        return self.meshes.terrain_level_of_detail(eye, ground)

    # ---- frame ------------------------------------------------------------------------------

    def prepare_frame(self, head: Camera, show_sphere: bool | None = None) -> FrameScene:
        """The scene objects for one frame seen from ``head`` (for stereo, the point between
        the eyes looking where the head looks); pass it to ``render`` for every eye. It holds
        until the next ``prepare_frame``, which may replace the meshes it names."""
        return self.meshes.prepare_frame(
            head, self.show_sphere if show_sphere is None else show_sphere
        )

    def render(self, target: moderngl.Framebuffer, request: FrameRequest) -> dict:
        """Draw the frame ``request`` asks for into its viewport of ``target``. Returns CPU
        milliseconds per stage and the exposure used."""
        viewport = request.viewport or (0, 0, *target.size)
        start = time.perf_counter()
        times = self._draw_scene(request, viewport[2:])
        return self._resolve(target, viewport, request, times, start)

    def _draw_scene(self, request: FrameRequest, size: tuple[int, int]) -> dict:
        """Draw the scene, in light, into the post chain's scene target of ``size``."""
        camera, sky, mode, debug = request.camera, request.sky, request.mode, request.debug
        ctx = self.ctx
        times = {}
        start = time.perf_counter()
        self.post.resize(*size)
        scene = request.scene
        if scene is None:
            scene = self.prepare_frame(camera, request.show_sphere)
        hdr_target = self.post.scene_framebuffer
        # A still's frames cast the shadows of the larger frame they stand for.
        shadow_size = tuple(round(side / request.footprint_scale) for side in size)
        self._shadow_frame = self._shadow_maps(
            scene, camera, sky, debug, shadow_size, request.moving
        )
        if self.wait_without_gil:
            finish_without_gil()  # the shadow maps, which the surface reads
        times["shadows_ms"] = _lap(start)

        with drawing_into(ctx, hdr_target):
            ctx.viewport = (0, 0, *self.post.size)
            hdr_target.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)  # alpha: no spread (tone.glsl)
            if not debug:
                self._draw_sky(camera, sky)
            times["sky_ms"] = _lap(start) - times["shadows_ms"]
            with render_state(ctx, moderngl.DEPTH_TEST):
                self._prepare_surface(camera, sky, mode, request.footprint_scale)
                for mesh in (scene.terrain, *scene.objects):
                    self._draw(mesh, camera, mode in BLENDED_MODES)
                if request.extra is not None:
                    request.extra(camera, sky, SceneShadows(self._shadows, self._shadow_frame))
            times["surface_ms"] = _lap(start) - times["shadows_ms"] - times["sky_ms"]
        return times

    def _resolve(self, target, viewport, request: FrameRequest, times: dict, start: float) -> dict:
        """Bloom, expose and tone-map the scene target into ``viewport`` of ``target``."""
        debug = request.debug
        light_only = debug or request.mode == "glints"  # glints alone would meter as black
        exposure = self.post.finish(
            target,
            viewport,
            self.exposure.for_frame(request.sky, request.exposure, light_only),
            bloom_strength=0.0 if debug else self.bloom_strength,
            tone_map=not debug,
        )
        if request.depth_out:
            self.post.copy_depth(target, viewport)
        drawn = ("shadows_ms", "sky_ms", "surface_ms")
        times["post_ms"] = _lap(start) - sum(times[k] for k in drawn)
        times["exposure"] = exposure
        return times

    def render_to_array(self, width: int, height: int, request: FrameRequest) -> np.ndarray:
        """The frame as an (height, width, 3) uint8 array, rows top-down."""
        return self._render_read(width, height, request)[0]

    def render_still(
        self, width: int, height: int, request: FrameRequest, samples: int = 1
    ) -> np.ndarray:
        """The frame drawn with ``samples``×``samples`` samples a pixel, as an (height, width, 3)
        uint8 array, rows top-down: as many frames of the scene's light, each moved by a
        fraction of a pixel (a ``samples``-th grid over it) and filtering the sand over that
        share of a pixel (``FrameRequest.footprint_scale``), so that each draws what a frame
        ``samples`` times as wide and high would at those points: the grains' outlines, their
        relief and the shadows' edges resolved within the pixel. Their light is averaged, as a
        camera's pixel gathers the light that falls on it, then bloomed, exposed (metered on
        the average unless the request fixes it) and tone-mapped once: a sparkle keeps the
        light it brings to its pixel. The spread of the light the tone curve takes
        (tone.glsl) is what the samples hold within them. A still fills its frame: a request
        with a viewport raises ValueError."""
        check_samples(samples)
        if request.viewport is not None:
            raise ValueError("a still fills its frame: its request takes no viewport")
        if samples == 1:
            return self.render_to_array(width, height, request)
        gathered = GatheredLight(width, height)
        for index in range(samples**2):
            sample = dataclasses.replace(
                request,
                camera=sample_camera(request.camera, samples, index, (width, height)),
                footprint_scale=1.0 / samples,
            )
            gathered.add(self.draw_light(sample, (width, height)))
        target = self._readback_target(width, height)
        self.resolve_light(target, (0, 0, width, height), request, gathered.scene())
        return self._read(target)

    def draw_light(self, request: FrameRequest, size: tuple[int, int]) -> np.ndarray:
        """The scene's light for ``request`` at ``size``, before bloom and the tone curve: the
        scene target's (height, width, 4) half floats, light and spread, rows from the bottom."""
        self._draw_scene(request, size)
        return self.scene_light()

    def scene_light(self) -> np.ndarray:
        """The light of the last frame drawn, as ``draw_light`` gives it."""
        if self.wait_without_gil:
            finish_without_gil()  # the drawing, which the read would wait for holding the lock
        width, height = self.post.size
        data = self.post.scene_texture.read()
        return np.frombuffer(data, np.float16).reshape(height, width, 4)

    def resolve_light(
        self,
        target: moderngl.Framebuffer,
        viewport,
        request: FrameRequest,
        scene: np.ndarray | None,
    ) -> dict:
        """Bloom, expose and tone-map ``scene`` (as ``draw_light`` gives it, the viewport's
        size; None: the light last drawn, still in the scene target) into ``viewport`` of
        ``target``, as ``render`` does its frame's light; the exposure is metered on it unless
        the request fixes it."""
        start = time.perf_counter()
        if scene is not None:
            self.post.resize(viewport[2], viewport[3])
            self.post.scene_texture.write(np.ascontiguousarray(scene, np.float16).tobytes())
        times = {"shadows_ms": 0.0, "sky_ms": 0.0, "surface_ms": 0.0}
        return self._resolve(target, viewport, request, times, start)

    def _render_read(self, width: int, height: int, request: FrameRequest):
        """The frame as render_to_array gives it, and render's timings."""
        target = self._readback_target(width, height)
        times = self.render(target, request)
        return self._read(target), times

    def _readback_target(self, width: int, height: int) -> moderngl.Framebuffer:
        if self._readback is None or self._readback.size != (width, height):
            self._release_readback()
            texture = self.ctx.texture((width, height), 4)
            self._readback = self.ctx.framebuffer([texture])
        return self._readback

    @staticmethod
    def _read(target: moderngl.Framebuffer) -> np.ndarray:
        width, height = target.size
        data = target.read(components=3, alignment=1)
        return np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3)[::-1].copy()

    def _draw_sky(self, camera: Camera, sky: SkyState) -> None:
        rotation_only = camera.view.astype(np.float64).copy()
        rotation_only[:3, 3] = 0.0
        inverse = np.linalg.inv(camera.projection.astype(np.float64) @ rotation_only)
        prog = self._sky
        set_matrix(prog, "u_inverse_view_projection", inverse)
        values = {
            "u_resolution": tuple(float(v) for v in self.post.size),
            **sky_uniforms(sky),
            **SKY_CONSTANTS,
        }
        for name, value in values.items():
            set_uniform(prog, name, value)
        with render_state(self.ctx):
            self._sky_vao.render(moderngl.TRIANGLES, vertices=3)

    def _shadow_maps(
        self, scene: FrameScene, camera: Camera, sky: SkyState, debug: bool, size, moving: bool
    ):
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
        meshes = scene.shadow_casters
        # Anything in the scene stands at most this far above the lowest ground in view.
        rise = max(mesh.top for mesh in meshes) + self.terrain.height_bound
        clearance = self.terrain.clearance(head.eye)
        return self._shadows.update(meshes, head, sky, clearance, rise, size, moving)

    @property
    def shadow_maps_drawn(self) -> int:
        """How many frames drew their shadow maps (the others kept the last ones)."""
        return self._shadows.maps_drawn

    @property
    def shadow_cascades_drawn(self) -> int:
        """How many cascade maps were drawn, over all frames."""
        return self._shadows.cascades_drawn

    def _prepare_surface(self, camera: Camera, sky: SkyState, mode: str, footprint: float) -> None:
        for prog in self._surfaces:
            self._prepare_program(prog, camera, sky, mode, footprint)

    def _prepare_program(
        self, prog, camera: Camera, sky: SkyState, mode: str, footprint: float
    ) -> None:
        if self.material is not None:
            self.material.bind(prog, 0)
        values = {
            **self.surface_switches(mode, footprint),
            "u_eye": _vec(camera.position),
            **sky_uniforms(sky, SURFACE_SKY),
        }
        for name, value in values.items():
            set_uniform(prog, name, value)
        self._shadows.bind(prog, self._shadow_frame)

    def surface_switches(self, mode: str, footprint_scale: float = 1.0) -> dict:
        """The surface programs' uniforms of the mode, the renderer's switches and the share of
        a pixel the sand is filtered over (``FrameRequest.footprint_scale``)."""
        return {
            "u_mode": mode_index(mode),
            "u_footprint_scale": float(footprint_scale),
            "u_relief": int(self.relief),
            "u_sharp_ripples": int(self.sharp_ripples),
            "u_unfiltered_ripples": int(not self.filter_ripples),
            "u_anisotropic": int(self.anisotropic),
            "u_tile_variation": int(self.tile_variation),
        }

    def _draw(self, mesh: SandMesh, camera: Camera, blended: bool) -> None:
        # Vertices are offsets from the mesh origin, and so is the eye in this matrix: small
        # numbers that keep their precision in float32 anywhere in the desert.
        view_projection = camera.projection.astype(np.float64) @ camera.view_relative_to(
            mesh.origin
        )
        self._shadows.bind_mesh(self._surfaces, self._shadow_frame, mesh.origin)
        if self.split_ranges:
            runs = self._range_runs(mesh, camera, blended)
        else:
            runs = ((0, mesh.indices), (0, mesh.indices))
        for prog, vao, (first, count) in zip(self._surfaces, mesh.vaos, runs, strict=True):
            if count == 0:
                continue
            set_matrix(prog, "u_view_projection", view_projection)
            set_uniform(prog, "u_origin", _vec(mesh.origin))
            set_uniform(prog, "u_no_ripples", mesh.no_ripples)
            vao.render(moderngl.TRIANGLES, vertices=count, first=first)

    def _range_runs(self, mesh: SandMesh, camera: Camera, blended: bool):
        """What of ``mesh`` each surface variant draws, (first index, count) for the near and
        the far one: the far variant shades only beyond the close limit and only in the
        blended modes (``sand_covers`` in sand_surface.glsl), so in other modes it draws
        nothing; of a mesh of rings, the near variant draws the rings that come within the
        close limit of the eye and the far one those that reach beyond it."""
        whole = (0, mesh.indices)
        if not blended:
            return whole, (0, 0)
        if mesh.rings is None or self.material is None:
            return whole, whole
        return mesh.ring_ranges(camera.eye, self.material.close_limit)

    # ---- lifetime ---------------------------------------------------------------------------

    def _release_readback(self) -> None:
        if self._readback is not None:
            for texture in self._readback.color_attachments:
                texture.release()
            self._readback.release()
            self._readback = None

    def release(self) -> None:
        self.meshes.release()
        self._release_readback()
        self._owned.release()
        self.post.release()


def _vec(v) -> tuple[float, float, float]:
    return tuple(float(c) for c in np.asarray(v).ravel()[:3])


def _lap(start: float) -> float:
    return (time.perf_counter() - start) * 1000.0
