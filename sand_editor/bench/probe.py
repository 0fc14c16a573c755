"""The material alone on a flat plane, rendered to HDR numpy arrays: the benchmark's measuring
instrument, with glint filters of its own that the product's programs do not contain.

Terrain, sky and post-processing would only add noise to the measurement of the material's
filtering, so the benchmark and the material's tests look at the plane.
"""

from __future__ import annotations

import time

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
from sand_editor.render.camera import Camera, camera_at_distance
from sand_editor.render.material import SandMaterial, surface_defines
from sand_editor.render.modes import mode_index

# Glint filters of the probe's program (shaders/bench/sand_probe.glsl, as FILTER_* #defines):
# "ours" is the product's; "expected" is the footprint moments' expected value without the
# sparkle, "reference" the reference's N×N multisampling, "none" one finest tap, and
# "ground-truth" every grain facet in the pixel; "ours-mean" and "ground-truth-mean" are the
# expectations of "ours" and "ground-truth" over their draws (energy without the draws' noise);
# "one-facet" is the light one mirroring facet of "ours" adds to its pixel (with "ours-mean", the
# draw's Poisson variance: the expected count is their ratio).
GLINT_FILTERS = {
    "ours": 0,
    "expected": 1,
    "reference": 2,
    "none": 3,
    "ground-truth": 4,
    "ours-mean": 5,
    "ground-truth-mean": 6,
    "one-facet": 7,
}

PLANE_HALF_EXTENT = 1.0e5  # metres: past the far plane of every probe view
PLANE_INNER_RADIUS = 1.0e-5  # metres: the innermost ring of the plane's mesh
PLANE_SEGMENTS = 48


def plane_vertices() -> np.ndarray:
    """Triangles of the plane y = 0 in rings doubling in radius about the origin (where every
    probe camera looks): each triangle spans coordinates of its own size, so interpolated
    positions and texture coordinates keep float32 precision (one quad ±1e5 m wide would
    interpolate them only to centimetres, and move texture-anchored detail with the camera)."""
    radii = [0.0]
    while radii[-1] < PLANE_HALF_EXTENT:
        radii.append(max(2.0 * radii[-1], PLANE_INNER_RADIUS))
    angles = np.linspace(0.0, 2.0 * np.pi, PLANE_SEGMENTS + 1)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    triangles = []
    for inner, outer in zip(radii, radii[1:], strict=False):
        for a, b in zip(ring[:-1], ring[1:], strict=True):
            quad = (inner * a, outer * a, outer * b, inner * b)
            triangles += [quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]]
    xz = np.array(triangles)
    vertices = np.zeros((len(xz), 11), dtype="f4")
    vertices[:, 0], vertices[:, 2] = xz[:, 0], xz[:, 1]
    vertices[:, 4] = 1.0  # normal
    vertices[:, 6] = 1.0  # tangent
    vertices[:, 9:11] = xz
    return vertices


class MaterialProbe:
    """Renders a :class:`SandMaterial` on the plane y = 0 under one sun and a sky."""

    def __init__(self, material: SandMaterial, width: int, height: int) -> None:
        self.material = material
        ctx = self.ctx = material.ctx
        self.width, self.height = width, height
        self.glint_filter = "ours"
        self.relief = False  # the grains' relief up close (u_relief, sand_relief.glsl)
        self.tile_variation = True  # the tile laid without a repeat (u_tile_variation)
        self.ripples = True  # the wind's ripples on the plane (u_no_ripples off)
        self.filter_ripples = True  # False: unfiltered, for a supersampled truth (as the renderer)
        self.ground_truth_samples = 16  # K: the ground truth's K×K albedo and slope samples
        # The renderer's surface program, on a plane: normal +y, tangent +x, uv = world xz;
        # compiled with the benchmark's glint filters (SAND_PROBE), which production lacks.
        filters = {
            f"FILTER_{name.upper().replace('-', '_')}": v for name, v in GLINT_FILTERS.items()
        }
        defines = surface_defines(SAND_PROBE=1, **filters)
        self._owned = GLObjects()
        keep = self._owned.keep
        self.program = keep(program(ctx, "terrain.glsl", defines))
        self.far_program = keep(program(ctx, "terrain.glsl", {**defines, "SAND_FAR_ONLY": 1}))
        self._buffer = keep(ctx.buffer(plane_vertices().tobytes()))
        attributes = ("a_position", "a_normal", "a_tangent", "a_uv")
        self._vaos = [
            keep(ctx.vertex_array(p, [(self._buffer, "3f 3f 3f 2f", *attributes)]))
            for p in (self.program, self.far_program)
        ]
        self._colour = keep(ctx.texture((width, height), 4, dtype="f4"))
        self._depth = keep(ctx.depth_renderbuffer((width, height)))
        self._fbo = keep(ctx.framebuffer([self._colour], self._depth))
        self.sun_direction = np.array([0.0, 0.6, -0.8])
        self.sun_radiance = np.array([3.0, 2.85, 2.6])
        self.sky_irradiance = np.array([0.35, 0.45, 0.6])

    def camera(self, distance_m: float, pitch_deg: float = 45.0, shift_px=(0.0, 0.0)) -> Camera:
        camera = camera_at_distance(distance_m, pitch_deg, self.width / self.height)
        if shift_px == (0.0, 0.0):
            return camera
        # A sub-pixel shift of the image: translate clip space after projection.
        shift = np.eye(4, dtype=np.float32)
        shift[0, 3] = 2.0 * shift_px[0] / self.width
        shift[1, 3] = 2.0 * shift_px[1] / self.height
        return Camera(view=camera.view, projection=(shift @ camera.projection).astype(np.float32))

    def render(
        self, camera: Camera, mode: str = "full", lower_half: bool = False
    ) -> tuple[np.ndarray, float]:
        """HDR radiance (height, width, 3), rows top-down, and the GPU time in milliseconds.

        ``lower_half`` shades only the frame's lower half (the rest stays 0): the sand nearest
        the camera, where a pixel's footprint is the view's own, not a grazing streak."""
        sun = self.sun_direction / np.linalg.norm(self.sun_direction)
        lights = {
            "u_eye": camera.position,
            "u_sun_direction": sun,
            "u_sun_radiance": self.sun_radiance,
            "u_moon_direction": -sun,
            "u_moon_radiance": np.zeros(3),
            "u_sky_irradiance": self.sky_irradiance,
        }
        for p in (self.program, self.far_program):
            set_matrix(p, "u_view_projection", camera.view_projection)
            p["u_origin"].value = (0.0, 0.0, 0.0)
            for name, value in lights.items():
                set_uniform(p, name, tuple(float(c) for c in value))
            p["u_mode"].value = mode_index(mode)
            self.material.bind(p)
            set_uniform(p, "u_no_ripples", 0.0 if self.ripples else 1.0)
            own = {"u_glint_filter": GLINT_FILTERS[self.glint_filter],
                   "u_ground_truth_samples": int(self.ground_truth_samples),
                   "u_relief": int(self.relief),
                   "u_sharp_ripples": 1,  # the renderer's filtering of the ripples
                   "u_unfiltered_ripples": int(not self.filter_ripples),
                   "u_anisotropic": 1,  # and of the grain textures
                   "u_tile_variation": int(self.tile_variation),
                   "u_footprint_scale": 1.0}  # fmt: skip
            for name, value in own.items():
                set_uniform(p, name, value)  # the far-only variant has no glints
        with drawing_into(self.ctx, self._fbo):
            self.ctx.viewport = (0, 0, self.width, self.height)
            self.ctx.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            self.ctx.finish()
            if lower_half:
                self.ctx.scissor = (0, 0, self.width, self.height // 2)
            start = time.perf_counter()
            try:
                with render_state(self.ctx, moderngl.DEPTH_TEST):
                    for vao in self._vaos:
                        vao.render(moderngl.TRIANGLES)
                self.ctx.finish()
            finally:
                self.ctx.scissor = None
            elapsed_ms = (time.perf_counter() - start) * 1e3
        pixels = np.frombuffer(self._colour.read(), dtype=np.float32).reshape(
            self.height, self.width, 4
        )
        return np.ascontiguousarray(pixels[::-1, :, :3]), elapsed_ms

    def release(self) -> None:
        self._owned.release()
