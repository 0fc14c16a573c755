"""The sand material on the GPU: filterable grain textures, the detail map and shading uniforms.

``SandMaterial.update(preset, grains=None)`` does only what a change needs: new grains when a
generation parameter changed (or the grains given), new glint moments when a field of cost
``moments`` (the share of clear grains) changed, and nothing but uniforms for every other
shading parameter.
``bind(program)`` hands all of it to a program that includes ``shaders/sand_surface.glsl``.
"""

from __future__ import annotations

from collections.abc import Callable

import moderngl
import numpy as np

from sand_editor.generator import GpuSandTextures, SandTextures, check_size, gl_generator
from sand_editor.generator.noise import (
    MAX_LAYERS,
    PROFILE_OFFSET,
    PROFILE_SCALE,
    NoiseConstants,
    colour_thresholds,
)
from sand_editor.generator.sizes import DEFAULT_RENDER_SIZE
from sand_editor.gl import (
    GLObjects,
    build_mipmaps_without_gil,
    draw_fullscreen,
    drawing_into,
    fullscreen_program,
    read_without_gil,
    set_uniform,
)
from sand_editor.preset import FIELDS, Preset
from sand_editor.render.facet_lobe import (
    LOBE_ALPHAS,
    LOBE_TILT_MAX_DEG,
    LOBE_TILTS_DEG,
    lobe_correction,
    lobe_row,
)
from sand_editor.render.far_brdf import SHADER_DEFINES as FAR_DEFINES
from sand_editor.render.far_brdf import five_normals_correction, grain_tilts, sphere_albedo_terms
from sand_editor.render.modes import mode_defines
from sand_editor.render.shadows import SHADER_DEFINES as SHADOW_DEFINES
from sand_editor.render.tile_copies import SHADER_DEFINES as TILE_COPY_DEFINES

GENERATION_BAND_ROWS = 64  # rows of new grains per step when generation is paced
DETAIL_MAP_SIZE = 256
# Close-range work is skipped where the far term's blend weight is above this.
CLOSE_CUTOFF = 0.999

# From the field table: the uniform of every shading field, and the fields whose change needs
# new glint moments (built from the grains by material_build.frag).
_SHADING_FIELDS = tuple(spec for spec in FIELDS if spec.section == "shading" and spec.uniform)
_MOMENT_FIELDS = tuple(spec for spec in _SHADING_FIELDS if spec.cost == "moments")
# Width² of the slope hole that the moments record and the surface shader reads back.
HOLE_SCALE2 = 0.25
# Facet edges spread log-uniformly from the preset's facet size down to this many times smaller
# (shaders/glint_facets.glsl).
FACET_SIZE_RANGE = 4.0


def facets_per_largest(size_range: float = FACET_SIZE_RANGE) -> float:
    """Facets in the area of one largest facet, their edges spread log-uniformly over
    ``size_range`` with each octave holding an equal share of the surface:
    ∫ d(ln r)/(r²·ln R) over r in [1/R, 1] = (R² − 1)/(2 ln R)."""
    return (size_range * size_range - 1.0) / (2.0 * float(np.log(size_range)))


FACETS_PER_LARGEST = facets_per_largest()
# The real angular radius of the sun (and the moon), radians: a facet mirrors it while the half
# vector stays within half of it (shaders/glint_facets.glsl; the exports' glint parameters).
LIGHT_ANGULAR_RADIUS = 0.00465
# The mip level whose clear-grain slopes measure the facet lobe's correction (facet_lobe.py).
LOBE_LEVEL = 2
# The fewest texels a grain cell (two grains) spans in the points the material is built from.
# The generator samples each grain's normal at texel centres: with cells of a texel or two, a
# regular grid of grains (no jitter) reads one slope over and over, and the moments hold none of
# the slopes between (a 256² tile of 256 cells of faceted grains read as one tilted plane, its
# far light twice its close light under a low sun). Such tiles are built from grains generated
# finer (supersampling), each texel the mean of its points, as each mip level is of the last.
MIN_CELL_TEXELS = 4
# The grains' mean shadowing table (relief_visibility.frag): light cosines, eye cosines and
# azimuths between them, and the points of the tile each entry averages.
RELIEF_TABLE = (9, 9, 7)
RELIEF_SAMPLES = 192
# Constants the material's shaders share with Python, as #defines: never copied by hand.
SHADER_DEFINES = {
    "HOLE_SCALE2": repr(HOLE_SCALE2),
    "FACET_SIZE_RANGE": repr(FACET_SIZE_RANGE),
    "FACETS_PER_LARGEST": repr(FACETS_PER_LARGEST),
    "LIGHT_ANGULAR_RADIUS": repr(LIGHT_ANGULAR_RADIUS),
    # The tallest a grain's profile gets: the top of the relief (material_build.frag).
    "PROFILE_TOP": repr(PROFILE_OFFSET + PROFILE_SCALE),
    "LAYER_COLOURS": MAX_LAYERS * 4,
    "MAX_LAYERS": MAX_LAYERS,
    **SHADOW_DEFINES,
    **FAR_DEFINES,
    "LOBE_TILTS": LOBE_TILTS_DEG.size,
    "LOBE_TILT_MAX": repr(float(np.radians(LOBE_TILT_MAX_DEG))),
    "RELIEF_TABLE": "ivec3({}, {}, {})".format(*RELIEF_TABLE),
    "RELIEF_SAMPLES": RELIEF_SAMPLES,
    **TILE_COPY_DEFINES,
}


def sphere_constants(average_albedo) -> dict:
    """Those terms of the tile's average albedo, as the uniforms of shaders/sand_far.glsl: once
    per material rather than per pixel."""
    kd = np.clip(np.asarray(average_albedo, dtype=np.float64), 1e-4, 1.0)
    c, floor = sphere_albedo_terms(kd)
    return {
        "u_sphere_c": tuple(float(x) for x in c),
        "u_sphere_floor": tuple(float(x) for x in floor),
        "u_sphere_inverse_albedo": tuple(float(x) for x in 1.0 / kd),
    }


def surface_defines(**extra) -> dict:
    """The #defines of a program that includes shaders/sand_surface.glsl."""
    return {**mode_defines(), **SHADER_DEFINES, **extra}


def _periodic_gradient(height: np.ndarray) -> np.ndarray:
    """Slopes (∂h/∂u, ∂h/∂v) of a periodic height map over a unit tile, by central differences."""
    n = height.shape[0]
    du = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) * (n / 2.0)
    dv = (np.roll(height, -1, axis=0) - np.roll(height, 1, axis=0)) * (n / 2.0)
    return np.stack([du, dv], axis=-1)


def detail_slopes(size: int, seed: int) -> np.ndarray:
    """Slopes of a tileable fine undulation (sums of random integer-frequency waves), max 1."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid((np.arange(size) + 0.5) / size, (np.arange(size) + 0.5) / size)
    height = np.zeros((size, size))
    for _ in range(24):
        fu, fv = rng.integers(-12, 13, size=2)
        height += np.sin(2 * np.pi * (fu * u + fv * v + rng.uniform())) / (1.0 + np.hypot(fu, fv))
    slopes = _periodic_gradient(height)
    return (slopes / np.abs(slopes).max()).astype(np.float32)


def supersampling(texture_size: int, period: int) -> int:
    """Generator points per texel each way (a power of two) for grain cells to span at least
    MIN_CELL_TEXELS points in a tile of ``texture_size`` texels and ``period`` cells."""
    factor = 1
    while texture_size * factor < MIN_CELL_TEXELS * period:
        factor *= 2
    return factor


class SandMaterial:
    """GPU resources of a sand preset, for ``shaders/sand_surface.glsl``."""

    def __init__(self, ctx: moderngl.Context, texture_size: int = DEFAULT_RENDER_SIZE) -> None:
        self.ctx = ctx
        self.texture_size = check_size(texture_size)
        self.preset: Preset | None = None  # whose shading is bound
        self.grains_generation = None  # the generation parameters of the grains held
        self.average_albedo = np.zeros(3, dtype=np.float32)
        self.lobe_correction = np.ones((LOBE_ALPHAS.size, LOBE_TILTS_DEG.size))
        self.close_cutoff = CLOSE_CUTOFF
        self._owned = GLObjects()
        keep = self._owned.keep
        self._build = keep(fullscreen_program(ctx, "material_build.frag", SHADER_DEFINES))
        size = self.texture_size
        # Made once and drawn over by every generation: a material owns a fixed set of objects.
        self._grains = GpuSandTextures.allocate(ctx, size)
        # The grains generated finer, for a tile too coarse for its grains (supersampling):
        # made while such grains are held, and their key (generation, factor).
        self._fine: GpuSandTextures | None = None
        self._fine_for = None
        self._built_for = None
        # Albedo is fine in half floats; the moments are not: the glint estimate subtracts
        # second moments and the hole from their means, which half floats round away.
        self.albedo = keep(self._filterable(ctx.texture((size, size), 4, dtype="f2")))
        self.glint_moments, self.spread_moments = (
            keep(self._filterable(ctx.texture((size, size), 4, dtype="f4"))) for _ in range(2)
        )
        self.hole_moments = keep(self._filterable(ctx.texture((size, size), 1, dtype="f4")))
        # Every texel's unit normal and its squares (nx, ny, nx², ny²): the footprint's
        # distribution of grain normals that the diffuse light is averaged over.
        self.normal_moments = keep(self._filterable(ctx.texture((size, size), 4, dtype="f4")))
        self._built = (
            self.albedo,
            self.glint_moments,
            self.spread_moments,
            self.hole_moments,
            self.normal_moments,
        )
        for texture in self._built:
            texture.build_mipmaps()  # the levels, made once; each build refills them
        self._build_fbo = keep(ctx.framebuffer(list(self._built)))
        lights, eyes, azimuths = RELIEF_TABLE
        self._visibility_program = keep(
            fullscreen_program(ctx, "relief_visibility.frag", SHADER_DEFINES)
        )
        self._visibility_target = keep(ctx.texture((lights * azimuths, eyes), 2, dtype="f4"))
        self._visibility_fbo = keep(ctx.framebuffer([self._visibility_target]))
        self.relief_visibility_texture = keep(
            ctx.texture3d((lights, eyes, azimuths), 2, dtype="f4")
        )
        self.relief_visibility_texture.repeat_x = False
        self.relief_visibility_texture.repeat_y = False
        self.relief_visibility_texture.repeat_z = False
        self.relief_visibility = np.ones((azimuths, eyes, lights), dtype=np.float32)
        self.diffuse_correction_texture = keep(
            ctx.texture3d((lights, eyes, azimuths), 1, dtype="f4")
        )
        self.diffuse_correction_texture.repeat_x = False
        self.diffuse_correction_texture.repeat_y = False
        self.diffuse_correction_texture.repeat_z = False
        self.detail = self._map(detail_slopes(DETAIL_MAP_SIZE, seed=3))

    @staticmethod
    def _filterable(texture: moderngl.Texture) -> moderngl.Texture:
        texture.repeat_x = texture.repeat_y = True
        texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        texture.anisotropy = 1.0
        return texture

    def _map(self, slopes: np.ndarray) -> moderngl.Texture:
        texture = self._owned.keep(
            self.ctx.texture(slopes.shape[1::-1], 2, slopes.tobytes(), dtype="f4")
        )
        self._filterable(texture)
        texture.build_mipmaps()
        return texture

    @property
    def max_lod(self) -> float:
        return float(np.log2(self.texture_size))

    def update(
        self,
        preset: Preset,
        grains: SandTextures | SandMaterial | None = None,
        between_bands: Callable[[], None] | None = None,
        cancelled: Callable[[], bool] | None = None,
    ) -> bool:
        """Shade with ``preset``, doing only the work its changes need.

        The one way grains come in. With ``grains`` (made elsewhere, e.g. read back from
        another context, or another material of this context and size, whose grains are copied
        on the GPU), those are taken and kept: the preset's shading is applied to them
        even while their generation is not yet the preset's, so a view waiting for its next
        tile never makes grains itself. Without, new grains are made here when the preset's
        generation differs from the grains the material holds (``grains_generation``).
        Where the tile is too coarse for the grains (``supersampling``), the material is built
        from their generation's grains generated finer, made here (or copied with another
        material's grains).

        With ``between_bands``, new grains are drawn in bands of ``GENERATION_BAND_ROWS`` rows
        and it is called after each: a thread making grains beside one that must keep drawing
        frames waits there, so the two share the GPU (or the CPU rasterizer's cores) in turns.
        ``cancelled`` is asked after each band too: when it says True the work stops there, the
        material holds no preset until its next update, and False is returned.
        """
        try:
            return self._update(preset, grains, between_bands, cancelled)
        except BaseException:
            self.preset = None  # half-made: the next update makes everything again
            self.grains_generation = None
            self._built_for = None
            raise

    def _update(self, preset, grains, between_bands, cancelled) -> bool:
        if isinstance(grains, SandMaterial):
            self._grains.copy_from(grains._grains)
            self._built_for = None
            self.grains_generation = grains.grains_generation
            if grains._fine is not None and grains._fine_for != self._fine_for:
                self._release_fine()
                self._fine = GpuSandTextures.allocate(self.ctx, grains._fine.size)
                self._fine.copy_from(grains._fine)
                self._fine_for = grains._fine_for
        elif grains is not None:
            self._upload(grains)
        elif self.grains_generation != preset.generation:
            constants = NoiseConstants.from_generation(preset.generation)
            self.preset = None  # until every band is drawn
            self.grains_generation = None
            self._built_for = None
            if not self._draw_grains(constants, self._grains, between_bands, cancelled):
                return False
            self.grains_generation = preset.generation
        if not self._fine_grains(between_bands, cancelled):
            self.preset = None
            return False
        build_key = (self.grains_generation, *(preset.get(spec.path) for spec in _MOMENT_FIELDS))
        if self._built_for != build_key:
            # The relief's mean shadowing is the grains' alone: made again with new grains only.
            new_grains = self._built_for is None or self._built_for[0] != build_key[0]
            self._build_textures(preset, new_grains)
            self._built_for = build_key
        self.preset = preset
        return True

    def _draw_grains(self, constants, target, between_bands, cancelled) -> bool:
        """Generate grains into ``target``, in bands where paced; False where cancelled."""
        rows = target.size if between_bands is None and cancelled is None else GENERATION_BAND_ROWS
        for _rows in gl_generator(self.ctx).render_in_bands(constants, target, rows):
            if between_bands is not None:
                between_bands()
            if cancelled is not None and cancelled():
                return False
        return True

    def _fine_grains(self, between_bands, cancelled) -> bool:
        """Hold the grains generated finer where the tile is too coarse for them (and none
        where it is not); False where cancelled."""
        generation = self.grains_generation
        factor = supersampling(self.texture_size, generation.period)
        key = (generation, factor)
        if self._fine_for == key:
            return True
        self._release_fine()
        if factor == 1:
            return True
        self._fine = GpuSandTextures.allocate(self.ctx, self.texture_size * factor)
        self._built_for = None
        constants = NoiseConstants.from_generation(generation)
        if not self._draw_grains(constants, self._fine, between_bands, cancelled):
            self._release_fine()
            return False
        self._fine_for = key
        return True

    def _release_fine(self) -> None:
        if self._fine is not None:
            self._fine.release()
        self._fine = None
        self._fine_for = None

    def _upload(self, textures: SandTextures) -> None:
        n = self.texture_size
        if textures.size != n:
            raise ValueError(f"grains are {textures.size}², the material is {n}²")
        if textures.generation is None:
            raise ValueError("grains must say which generation made them (SandTextures.generation)")
        normal_height = np.empty((n, n, 4), dtype=np.float32)
        normal_height[..., :3] = textures.normal
        normal_height[..., 3] = textures.height
        layer_grain = np.empty((n, n, 2), dtype=np.uint32)
        layer_grain[..., 0] = textures.layer.astype(np.int32) + 1
        layer_grain[..., 1] = textures.grain_id
        self._grains.normal_height.write(normal_height)
        self._grains.layer_grain.write(layer_grain)
        self._built_for = None
        self.grains_generation = textures.generation

    def _build_textures(self, preset: Preset, new_grains: bool = True) -> None:
        # Coloured by the generation of the grains held, which may not yet be the preset's.
        nc = NoiseConstants.from_generation(self.grains_generation)
        program = self._build
        source = self._fine if self._fine is not None else self._grains
        source.normal_height.use(location=0)
        source.layer_grain.use(location=1)
        program["u_normal_height"].value = 0
        program["u_layer_grain"].value = 1
        program["u_supersample"].value = source.size // self.texture_size
        program["u_base_color"].value = tuple(nc.base_color)
        colours = nc.layer_colors.reshape(MAX_LAYERS * 4, 3).astype(np.float32)
        program["u_layer_colors"].write(colours.tobytes())
        program["u_layer_light"].write(nc.layer_light.astype(np.float32).tobytes())
        program["u_colour_thresholds"].value = tuple(
            int(t) for t in colour_thresholds(nc.cumulative_weights)
        )
        for spec in _MOMENT_FIELDS:
            program[spec.uniform].value = preset.get(spec.path)
        with drawing_into(self.ctx, self._build_fbo):
            self.ctx.viewport = (0, 0, self.texture_size, self.texture_size)
            draw_fullscreen(self.ctx, program)
        # Waiting for the draws without Python's lock: a thread building a material while
        # another draws frames (the VR viewer) lets the frames go on meanwhile.
        for texture in self._built:
            build_mipmaps_without_gil(texture)
        # The last mip level is the average of the whole tile: the far-field colour.
        top = int(self.max_lod)
        texel = np.frombuffer(read_without_gil(self.albedo, level=top), dtype=np.float16)
        texel = texel.astype(np.float32)
        self.average_albedo = texel[:3].copy()
        self.lobe_correction = self._measure_lobe_correction()
        if new_grains:
            self.relief_visibility = self._measure_relief_visibility()
            self._measure_diffuse_correction()

    def _measure_relief_visibility(self) -> np.ndarray:
        """The grains' mean shadowing of a light as an eye sees them, (azimuth, eye cosine,
        light cosine) (relief_visibility.frag), into the texture the surface reads with the
        mean depth at which the eye's ray meets them (a share of sand_relief.glsl's
        relief_depth_tc) beside it."""
        program = self._visibility_program
        self.albedo.use(location=0)
        set_uniform(program, "u_albedo", 0)
        set_uniform(program, "u_texture_size", float(self.texture_size))
        set_uniform(program, "u_grain_cell", 1.0 / float(self.grains_generation.period))
        lights, eyes, azimuths = RELIEF_TABLE
        with drawing_into(self.ctx, self._visibility_fbo):
            self.ctx.viewport = (0, 0, lights * azimuths, eyes)
            draw_fullscreen(self.ctx, program)
        flat = np.frombuffer(read_without_gil(self._visibility_target), dtype=np.float32)
        table = flat.reshape(eyes, azimuths, lights, 2).transpose(1, 0, 2, 3).copy()
        self.relief_visibility_texture.write(table.tobytes())
        return table[..., 0].copy()

    def _measure_diffuse_correction(self) -> None:
        """What the five normals' diffuse light misses of the grains' own over the whole tile
        (far_brdf.five_normals_correction), (azimuth, eye cosine, light cosine) at the relief
        table's directions (sand_relief.glsl's direction_table_at), into the texture the
        surface reads."""
        if self._fine is not None:
            # The grains' own normals, not their means over a texel (a tilt's light is not
            # linear in it): every point, since a cell spans only a few.
            size = self._fine.size
            finest = np.frombuffer(read_without_gil(self._fine.normal_height), dtype=np.float32)
            tilts = grain_tilts(finest.reshape(size, size, 4)[..., :2])
        else:
            size = self.texture_size
            finest = np.frombuffer(read_without_gil(self.normal_moments), dtype=np.float32)
            # Every other texel each way: a quarter of the count, each band's share within
            # 0.0013.
            tilts = grain_tilts(finest.reshape(size, size, 4)[::2, ::2, :2])
        top = int(self.max_lod)
        tile = np.frombuffer(read_without_gil(self.normal_moments, level=top), dtype=np.float32)
        lights, eyes, azimuths = RELIEF_TABLE
        cos_light = np.maximum(np.linspace(0.0, 1.0, lights), 0.02)
        cos_eye = np.maximum(np.linspace(0.0, 1.0, eyes), 0.02)
        azimuth = np.linspace(0.0, np.pi, azimuths)
        sin_eye = np.sqrt(1.0 - cos_eye * cos_eye)
        eye = np.stack(
            [
                np.outer(np.cos(azimuth), sin_eye),
                np.outer(np.sin(azimuth), sin_eye),
                np.broadcast_to(cos_eye, (azimuths, eyes)),
            ],
            axis=-1,
        )
        table = np.empty((azimuths, eyes, lights), dtype=np.float32)
        for i, c in enumerate(cos_light):
            light = np.array([np.sqrt(1.0 - c * c), 0.0, c])
            table[..., i] = five_normals_correction(tilts, tile[:4], light, eye)
        self.diffuse_correction_texture.write(table.tobytes())

    def _measure_lobe_correction(self) -> np.ndarray:
        """The rotated facet lobe's light over the slope moments' (facet_lobe.py), measured on
        the clear grains' mean slopes at mip level LOBE_LEVEL, each the mean of 4×4 texels
        (a paper-default grain cell spans 7 of them at 1024²; on the finest periods a texel there
        mixes grains, which narrows the measured slopes a little)."""
        level = min(LOBE_LEVEL, int(self.max_lod))
        side = max(self.texture_size >> level, 1)
        texels = np.frombuffer(read_without_gil(self.glint_moments, level=level), dtype=np.float32)
        texels = texels.reshape(side * side, 4).astype(np.float64)
        weights = texels[:, 0]
        slopes = texels[:, 1:3] / np.where(weights > 0.0, weights, 1.0)[:, None]
        return lobe_correction(slopes, weights)

    @property
    def close_limit(self) -> float:
        """Distance (metres) beyond which the blend weight exceeds the close cutoff."""
        a, b = self.preset.shading.sigmoid_a, self.preset.shading.sigmoid_b
        cutoff = self.close_cutoff
        if cutoff >= 1.0:
            return 1.0e30
        return float(b + np.log(cutoff / (1.0 - cutoff)) / a)

    def textures(self) -> dict:
        """The sampler uniform of each texture a program including sand_surface.glsl reads."""
        if self.preset is None:
            raise RuntimeError("SandMaterial.textures before update(preset)")
        return {
            "u_albedo": self.albedo,
            "u_glint_moments": self.glint_moments,
            "u_spread_moments": self.spread_moments,
            "u_hole_moments": self.hole_moments,
            "u_normal_moments": self.normal_moments,
            "u_detail": self.detail,
            "u_layer_grain": self._grains.layer_grain,  # the tile's copies' borders
            "u_relief_visibility": self.relief_visibility_texture,
            "u_diffuse_correction": self.diffuse_correction_texture,
        }

    def uniform_values(self) -> dict:
        """Every other uniform of sand_surface.glsl the material sets, by name: what ``bind``
        sets, and what a port of the renderer (the web export) sets the same way."""
        if self.preset is None:
            raise RuntimeError("SandMaterial.uniform_values before update(preset)")
        values = {spec.uniform: self.preset.get(spec.path) for spec in _SHADING_FIELDS}
        values["u_facet_size"] = self.preset.largest_facet_m * 1.0e6
        values.update(
            u_average_albedo=tuple(float(c) for c in self.average_albedo),
            **sphere_constants(self.average_albedo),
            u_texture_size=float(self.texture_size),
            u_grain_cell=1.0 / float(self.grains_generation.period),
            u_max_lod=self.max_lod,
            u_close_cutoff=float(self.close_cutoff),
            u_close_limit=self.close_limit,
        )
        alpha = self.preset.shading.facet_roughness
        values["u_lobe_correction"] = tuple(float(c) for c in lobe_row(self.lobe_correction, alpha))
        return values

    def bind(self, program, first_unit: int = 0) -> int:
        """Bind the textures and set the uniforms of a program including sand_surface.glsl."""
        if self.preset is None:
            raise RuntimeError("SandMaterial.bind before update(preset)")
        units = self.textures()
        # Every texture keeps its own unit whether or not a program uses it: programs sharing
        # these bindings (a surface drawn in near and far passes) then never disagree.
        for offset, (name, texture) in enumerate(units.items()):
            texture.use(location=first_unit + offset)
            set_uniform(program, name, first_unit + offset)
        for name, value in self.uniform_values().items():
            set_uniform(program, name, value)
        return first_unit + len(units)

    def release(self) -> None:
        """Release every GL object the material made (safe to call twice)."""
        self._release_fine()
        if self._grains is not None:
            self._grains.release()
            self._grains = None
        self._owned.release()
