"""Shadows of the sun, or at night of the moon: cascaded shadow maps fitted to the view.

The view's frustum, from where the nearest ground can be to ``SHADOW_DISTANCE_M`` (further
when the eye is high), is cut into one to ``CASCADES`` slices whose depths grow geometrically
(each at most ``MAX_SLICE_RATIO`` deep), and each slice is covered by one orthographic map seen
from the light: a sphere around the slice, so its size does not change as the head turns, with
its centre snapped to the map's texels, so edges do not crawl while the head moves. The maps
share one depth texture (a 2 × 2 atlas).
Casters are taken from as far towards the light as anything in the scene can rise above the
lowest ground, so a dune a kilometre away still shades the sand at the viewer's feet at sunset.

A frame's maps are drawn once, for the head (``prepare_frame``'s camera), and both eyes read the
same maps; they are not drawn again while the light, the fit and the meshes stay the same (an
editor's still view, a paused clock). Surfaces read them in shaders/shadows.glsl: the light's
radiance, diffuse and glints alike, is scaled by what of it reaches the point, the depth tests
of the 2 × 2 texels around it weighted bilinearly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from sand_editor.gl import GLObjects, drawing_into, program, render_state, set_matrix, set_uniform
from sand_editor.render.camera import Camera

CASCADES = 4  # at most; the atlas holds four
MAX_SLICE_RATIO = 10.0  # a cascade's slice of the view reaches at most this ratio deep
# Texels per edge of one cascade's map: the frame's larger side, rounded up to a power of two,
# within these bounds (a cascade spans about the frame's width at its far end). Drawing a map
# costs its texels on a CPU rasterizer, so a small frame gets small maps.
CASCADE_SIZES = (512, 2048)
SHADOW_DISTANCE_M = 300.0  # shadows reach this far from a viewer near the ground
SHADOW_UNIT = 15  # the texture unit of the map: above any the material uses
MAX_REACH_M = 3000.0  # no caster further towards the light than this is taken
FIT_ROOM = 1.06  # a cascade's sphere is this much wider than its slice of the view needs
MIN_LIGHT_HEIGHT = 0.01  # the sine of the lowest light elevation whose reach is followed
NORMAL_OFFSET_TEXELS = 1.5  # receivers are looked up this far out along their normal
POLYGON_OFFSET = (2.0, 4.0)  # slope-scaled and constant depth bias of the casters
LIGHT_DECIMALS = 4  # the maps' light direction is rounded to this many decimals
# A map drawn for a light at most this far from the present one, whose sphere still holds its
# slice of the view, is kept a while: of such maps, one is drawn again per frame, the one drawn
# longest ago. Any other change (a new size, another light, new meshes) draws the map at once.
MAX_LIGHT_LAG_DEG = 1.0
REFRESHED_PER_FRAME = 1
_LIGHTS = {"sun": 0, "moon": 1}
# What programs that include shaders/shadows.glsl are compiled with.
SHADER_DEFINES = {"SHADOW_CASCADES": CASCADES}


@dataclass(frozen=True)
class Cascade:
    """One orthographic map: a sphere (``center``, ``radius``) seen along the light, with
    casters taken from up to ``reach`` metres towards the light beyond it."""

    center: np.ndarray  # world, float64, snapped to the map's texels
    radius: float
    size: int  # texels per edge of its map
    axes: np.ndarray  # rows: the map's x and y across the light, and the direction to it
    reach: float
    near_m: float  # the slice of the view it covers (distances from the eye)
    far_m: float
    corners: np.ndarray  # the slice's eight corners, world, float64

    def shows_the_same(self, other: Cascade) -> bool:
        """Whether ``other``'s map would hold the same depths as this one's."""
        same_box = (self.radius, self.reach, self.size) == (other.radius, other.reach, other.size)
        return (same_box and np.array_equal(self.center, other.center)
                and np.array_equal(self.axes, other.axes))  # fmt: skip

    def covers(self, points: np.ndarray) -> bool:
        """Whether every point lies inside the sphere (two texels in from its edge)."""
        reach = self.radius - 2.0 * self.texel_m
        return bool(np.all(np.linalg.norm(points - self.center, axis=1) <= reach))

    def light_angle_to(self, direction) -> float:
        """Degrees between the light this map was drawn for and ``direction``."""
        return math.degrees(math.acos(min(max(float(self.axes[2] @ direction), -1.0), 1.0)))

    @property
    def texel_m(self) -> float:
        return 2.0 * self.radius / self.size

    def clip_matrix(self, origin) -> np.ndarray:
        """float64 world → clip for positions relative to ``origin``: x, y across the light in
        [−1, 1], z from −1 at ``reach`` towards the light to 1 at the sphere's far side."""
        offset = np.asarray(origin, dtype=np.float64) - self.center
        low, high = -self.radius, self.radius + self.reach
        matrix = np.identity(4)
        matrix[:2, :3] = self.axes[:2] / self.radius
        matrix[:2, 3] = self.axes[:2] @ offset / self.radius
        matrix[2, :3] = -2.0 * self.axes[2] / (high - low)
        matrix[2, 3] = (high + low - 2.0 * (self.axes[2] @ offset)) / (high - low)
        return matrix

    def lookup_matrix(self, origin) -> np.ndarray:
        """Positions relative to ``origin`` → the cascade's map coordinates and depth in [0, 1]."""
        to_unit = np.identity(4)
        to_unit[:3, :3] *= 0.5
        to_unit[:3, 3] = 0.5
        return to_unit @ self.clip_matrix(origin)


def shadow_light(sky) -> tuple[str, np.ndarray] | None:
    """The light that casts the shadows, ("sun" | "moon", unit direction towards it): the
    brighter of the two that shine; None when neither does."""
    lights = [
        (float(np.sum(sky.sun_radiance)), "sun", sky.sun_direction),
        (float(np.sum(sky.moon_radiance)), "moon", sky.moon_direction),
    ]
    strength, name, direction = max(lights, key=lambda light: light[0])
    if not strength > 0.0:
        return None
    direction = np.asarray(direction, dtype=np.float64)
    return name, direction / np.linalg.norm(direction)


def cascade_splits(near: float, far: float, count: int = CASCADES) -> np.ndarray:
    """``count`` + 1 distances from ``near`` to ``far``, each slice the same ratio deep."""
    return near * (far / near) ** (np.arange(count + 1) / count)


def nearest_depth(head: Camera, boxes) -> float:
    """The least view depth (metres ahead of ``head``'s eye) of the boxes ((2, 3) world min
    and max corners) that lie at least partly ahead of it; inf when none does."""
    forward = np.asarray(head.forward, dtype=np.float64)
    eye = np.asarray(head.eye, dtype=np.float64)
    nearest = math.inf
    for low, high in boxes:
        corners = np.array([[(low, high)[k >> i & 1][i] for i in range(3)] for k in range(8)])
        depths = (corners - eye) @ forward
        if depths.max() > 0.0:
            nearest = min(nearest, max(float(depths.min()), 0.0))
    return nearest


def cascade_size(frame_size) -> int:
    """The cascades' map size for a frame of ``frame_size`` (width, height) pixels."""
    side = max(int(max(frame_size)), 1)
    return int(min(max(2 ** math.ceil(math.log2(side)), CASCADE_SIZES[0]), CASCADE_SIZES[1]))


def fit_cascades(
    head: Camera,
    light,
    clearance: float,
    rise: float,
    size: int = CASCADE_SIZES[0],
    count: int = CASCADES,
    nearest: float = math.inf,
) -> tuple[Cascade, ...]:
    """The cascades of a view from ``head`` at ``clearance`` metres above the ground under a
    light in unit direction ``light``; ``rise`` is how far anything in the scene stands above
    the lowest ground the view can see (it sets how far towards the light casters are taken),
    ``nearest`` the least view depth of any object standing on it (a desk the user leans
    over): the first cascade starts there, so what is closest gets the finest map."""
    light = np.asarray(light, dtype=np.float64)
    near_plane, far_plane = _depth_range(head.projection)
    clearance = max(float(clearance), 0.0)
    near = max(near_plane, min(0.5 * clearance, float(nearest)), 1e-4)
    far = min(far_plane, max(SHADOW_DISTANCE_M, 20.0 * clearance))
    near = min(near, 0.5 * far)
    # The four corners of the view at unit depth, in world directions from the eye.
    inverse = np.linalg.inv(head.projection.astype(np.float64))
    corners = []
    for x, y in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        p = inverse @ np.array([x, y, -1.0, 1.0])
        corners.append(p[:3] / p[3] / -(p[2] / p[3]))
    rotation = head.view_relative_to(head.eye)[:3, :3].T
    directions = np.array(corners) @ rotation.T
    axes = _light_axes(light)
    reach = min(MAX_REACH_M, max(float(rise), 0.0) / max(light[1], MIN_LIGHT_HEIGHT))
    # No more cascades than slices MAX_SLICE_RATIO deep need: a high eye sees the ground from
    # tens of metres to a few hundred, which two maps hold.
    count = min(count, max(1, math.ceil(math.log(far / near) / math.log(MAX_SLICE_RATIO))))
    splits = cascade_splits(near, far, count)
    cascades = []
    for near_m, far_m in zip(splits[:-1], splits[1:], strict=True):
        points = np.concatenate([directions * near_m, directions * far_m]) + head.eye
        center = points.mean(axis=0)
        radius = float(np.max(np.linalg.norm(points - center, axis=1)))
        # Rounded up to a step of 2^(1/8), so a jittering field of view keeps it, with room
        # for the head to move a little before the map must be drawn again.
        radius = 2.0 ** (math.ceil(8.0 * math.log2(FIT_ROOM * radius)) / 8.0)
        texel = 2.0 * radius / size
        across = axes[:2] @ center
        center = center + axes[:2].T @ (np.round(across / texel) * texel - across)
        slice_ = (float(near_m), float(far_m), points)
        cascades.append(Cascade(center, radius, size, axes, reach, *slice_))
    return tuple(cascades)


@dataclass(frozen=True)
class ShadowFrame:
    """What a frame's surfaces need to read the maps: the light and the cascades."""

    light: str
    cascades: tuple[Cascade, ...]


class SunShadows:
    """The shadow maps and their drawing. ``maps_drawn`` counts the frames whose maps were
    drawn (not taken over unchanged from the frame before), ``cascades_drawn`` the maps."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._owned = GLObjects()
        keep = self._owned.keep
        self.program = keep(program(ctx, "shadow_depth.glsl"))
        self.depth: moderngl.Texture | None = None
        self._framebuffer: moderngl.Framebuffer | None = None
        self._drawn: dict[int, tuple[Cascade, tuple, int]] = {}  # cascade, meshes, frame
        self._frames = 0
        self.maps_drawn = 0
        self.cascades_drawn = 0

    def _resize(self, size: int) -> None:
        """A 2 × 2 atlas of ``size``² cascades (kept while the size stays)."""
        if self.depth is not None and self.depth.size[0] == 2 * size:
            return
        self._release_maps()
        self.depth = self.ctx.depth_texture((2 * size, 2 * size))
        # Read with texelFetch and compared in the shader (shaders/shadows.glsl), which a
        # plain sampler shares with the material's without a sampler-type conflict.
        self.depth.compare_func = ""
        self.depth.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._framebuffer = self.ctx.framebuffer(depth_attachment=self.depth)
        self._drawn.clear()

    def _release_maps(self) -> None:
        for obj in (self._framebuffer, self.depth):
            if obj is not None:
                obj.release()
        self._framebuffer = self.depth = None

    def update(
        self, meshes, head: Camera, sky, clearance: float, rise: float, frame_size, moving=False
    ):
        """The ``ShadowFrame`` of a frame drawing ``meshes`` (each with ``origin``,
        ``serial``, ``depth_vao``, ``indices``, ``bounds`` (world (min, max) corners, or None
        for the ground) and, for a mesh of rings, ``rings`` and ``ring_center``) in a frame of
        ``frame_size`` pixels; each cascade's map is drawn again only when what it shows
        changed. None when no light shines. While ``moving``, a map the view alone moved off
        (same meshes, the light within MAX_LIGHT_LAG_DEG) waits its turn like one the light
        moved off: a point its map no longer holds takes the next cascade's, or the light
        unshadowed, until then."""
        chosen = shadow_light(sky)
        if chosen is None:
            return None
        name, direction = chosen
        # The maps follow the light in steps of a hundredth of a degree or so: a playing clock
        # moves the sun by less than that in a frame, and far cascades are then kept.
        direction = np.round(direction, LIGHT_DECIMALS)
        direction /= np.linalg.norm(direction)
        size = cascade_size(frame_size)
        self._resize(size)
        boxes = [mesh.bounds for mesh in meshes if mesh.bounds is not None]
        nearest = nearest_depth(head, boxes)
        fitted = fit_cascades(head, direction, clearance, rise, size, nearest=nearest)
        serials = (name, *(mesh.serial for mesh in meshes))
        self._frames += 1
        urgent, waiting = [], []
        for index, cascade in enumerate(fitted):
            drawn = self._drawn.get(index)
            if drawn is None or drawn[1] != serials:
                urgent.append(index)
                continue
            old = drawn[0]
            if old.shows_the_same(cascade):
                continue
            kept = moving or (old.radius == cascade.radius and old.covers(cascade.corners))
            if kept and old.light_angle_to(direction) <= MAX_LIGHT_LAG_DEG:
                waiting.append(index)
            else:
                urgent.append(index)
        waiting.sort(key=lambda index: self._drawn[index][2])
        redraw = sorted(urgent + waiting[:REFRESHED_PER_FRAME])
        if redraw:
            self._draw(meshes, fitted, redraw)
            for index in redraw:
                self._drawn[index] = (fitted[index], serials, self._frames)
            self.maps_drawn += 1
            self.cascades_drawn += len(redraw)
        # Each cascade as its map was drawn: lookups use the matrices the map holds.
        return ShadowFrame(name, tuple(self._drawn[i][0] for i in range(len(fitted))))

    def _draw(self, meshes, cascades, indices) -> None:
        ctx = self.ctx
        with drawing_into(ctx, self._framebuffer):
            ctx.polygon_offset = POLYGON_OFFSET
            try:
                with render_state(ctx, moderngl.DEPTH_TEST):
                    for index in indices:
                        cascade = cascades[index]
                        column, row = index % 2, index // 2
                        size = cascade.size
                        tile = (column * size, row * size, size, size)
                        ctx.viewport = tile
                        self._framebuffer.clear(depth=1.0, viewport=tile)
                        for mesh in meshes:
                            clip = cascade.clip_matrix(mesh.origin)
                            set_matrix(self.program, "u_light_clip", clip)
                            first, count = caster_range(mesh, cascade)
                            if count > 0:
                                mesh.depth_vao.render(
                                    moderngl.TRIANGLES, vertices=count, first=first
                                )
            finally:
                ctx.polygon_offset = (0.0, 0.0)

    def bind(self, prog, frame: ShadowFrame | None) -> None:
        """The map and the light of ``frame`` (no shadows when it is None) for a surface program."""
        set_uniform(prog, "u_shadow_cascades", 0 if frame is None else len(frame.cascades))
        if frame is None:
            return
        self.depth.use(location=SHADOW_UNIT)
        set_uniform(prog, "u_shadow_map", SHADOW_UNIT)
        set_uniform(prog, "u_shadow_light", _LIGHTS[frame.light])
        set_uniform(prog, "u_shadow_size", frame.cascades[0].size)
        fade = frame.cascades[-1]
        set_uniform(prog, "u_shadow_fade", (0.8 * fade.far_m, fade.far_m))

    def bind_mesh(self, programs, frame: ShadowFrame | None, origin) -> None:
        """Each cascade's lookup matrix and normal offset for a mesh at ``origin``, in every
        program that draws it."""
        if frame is None:
            return
        # The arrays are CASCADES long; the cascades not in use read nothing (u_shadow_cascades).
        matrices = np.zeros((CASCADES, 4, 4))
        offsets = [0.0] * CASCADES
        for index, cascade in enumerate(frame.cascades):
            matrices[index] = cascade.lookup_matrix(origin)
            offsets[index] = NORMAL_OFFSET_TEXELS * cascade.texel_m
        for prog in programs:
            set_matrix(prog, "u_shadow_matrix", matrices)
            set_uniform(prog, "u_shadow_offset", offsets)

    def release(self) -> None:
        self._release_maps()
        self._owned.release()


@dataclass(frozen=True)
class SceneShadows:
    """One frame's shadow maps (``frame`` None: no shadows) as any program drawing into the
    scene binds them: the sand's, and the props' (``shaders/vr_props.glsl``)."""

    maps: SunShadows
    frame: ShadowFrame | None

    def bind(self, prog, origin) -> None:
        """The maps, the light and the lookups of a mesh whose positions are relative to
        ``origin``, into ``prog`` (which includes shaders/shadows.glsl)."""
        self.maps.bind(prog, self.frame)
        self.maps.bind_mesh((prog,), self.frame, origin)


def caster_range(mesh, cascade: Cascade) -> tuple[int, int]:
    """(first index, index count) of the mesh's triangles that can cast into the cascade: for a
    mesh of rings, the rings from the cascade's sphere out to the reach towards the light;
    every triangle of any other mesh."""
    rings = getattr(mesh, "rings", None)
    if rings is None or len(rings) < 2:
        return 0, mesh.indices
    per_band = mesh.indices // (len(rings) - 1)
    light = cascade.axes[2]
    across = cascade.reach * math.hypot(light[0], light[2]) + cascade.radius
    distance = math.hypot(*(cascade.center[[0, 2]] - mesh.ring_center))
    first = max(int(np.searchsorted(rings, distance - across, side="right")) - 1, 0)
    last = min(int(np.searchsorted(rings, distance + across, side="left")), len(rings) - 1)
    return first * per_band, max(last - first, 0) * per_band


def _depth_range(projection: np.ndarray) -> tuple[float, float]:
    """(near, far) of an OpenGL perspective projection; far is inf where float32 has rounded
    the far plane away (a near plane a million times closer)."""
    a, b = float(projection[2, 2]), float(projection[2, 3])
    return b / (a - 1.0), (b / (a + 1.0) if a + 1.0 < 0.0 else math.inf)


def _light_axes(light: np.ndarray) -> np.ndarray:
    """Rows: two unit axes across the light, then the light's direction."""
    hint = np.array([0.0, 0.0, 1.0]) if abs(light[1]) > 0.99 else np.array([0.0, 1.0, 0.0])
    x = np.cross(hint, light)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(light, x), light])
