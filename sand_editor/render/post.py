"""HDR scene target, bloom and tone mapping (``shaders/post.glsl``).

Bloom has no threshold: every pixel spreads a small share of its energy (Jimenez 2014, as in
Call of Duty: Advanced Warfare), so glints bloom because they are bright, not because they pass a
cut-off that would make them pop in and out.
"""

from __future__ import annotations

from collections.abc import Callable

import moderngl
import numpy as np

from sand_editor.gl import (
    GLObjects,
    build_mipmaps_without_gil,
    draw_fullscreen,
    drawing_into,
    finish_without_gil,
    fullscreen_program,
    read_without_gil,
    render_state,
    set_uniform,
)

BLOOM_LEVELS = 5
DEFAULT_BLOOM_STRENGTH = 0.04
UPSAMPLE_RADIUS = 1.0  # source texels between the tent's taps
METER_SIZE = 16  # texels per side of the exposure's metering target


class PostChain:
    """Owns the HDR scene framebuffer (RGBA16F + depth) and the bloom chain of one size."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self.size: tuple[int, int] | None = None
        self.scene_texture: moderngl.Texture | None = None
        self.depth_texture: moderngl.Texture | None = None
        self.scene_framebuffer: moderngl.Framebuffer | None = None
        self._levels: list[tuple[moderngl.Texture, moderngl.Framebuffer]] = []
        # Wait for each pass's source without Python's lock (see SandRenderer.wait_without_gil).
        self.wait_without_gil = False
        # What lives as long as the chain; the size-dependent targets are made by resize().
        self._owned = GLObjects()
        keep = self._owned.keep
        self._downsample = keep(fullscreen_program(ctx, "post.glsl", {"BLOOM_DOWNSAMPLE": 1}))
        self._upsample = keep(fullscreen_program(ctx, "post.glsl", {"BLOOM_UPSAMPLE": 1}))
        self._resolve = keep(fullscreen_program(ctx, "post.glsl", {"RESOLVE": 1}))
        self._meter = keep(fullscreen_program(ctx, "post.glsl", {"METER": 1}))
        self._depth_copy = keep(fullscreen_program(ctx, "post.glsl", {"DEPTH_COPY": 1}))
        self._meter_texture = keep(ctx.texture((METER_SIZE, METER_SIZE), 1, dtype="f4"))
        self._meter_texture.build_mipmaps()
        self._meter_fbo = keep(ctx.framebuffer([self._meter_texture]))

    def resize(self, width: int, height: int) -> None:
        """Reallocate the targets for a ``width`` × ``height`` frame (no-op when unchanged)."""
        width, height = int(width), int(height)
        if width < 1 or height < 1:
            raise ValueError(f"PostChain.resize: size must be positive, got {width}×{height}")
        if self.size == (width, height):
            return
        self._release_targets()
        ctx = self.ctx
        self.scene_texture = self._hdr_texture((width, height))
        self.depth_texture = ctx.depth_texture((width, height))
        self.depth_texture.compare_func = ""  # read as depths (copy_depth), not compared
        self.scene_framebuffer = ctx.framebuffer([self.scene_texture], self.depth_texture)
        for level in range(BLOOM_LEVELS):
            size = (max(1, width >> (level + 1)), max(1, height >> (level + 1)))
            texture = self._hdr_texture(size)
            self._levels.append((texture, ctx.framebuffer([texture])))
        self.size = (width, height)

    def _hdr_texture(self, size: tuple[int, int]) -> moderngl.Texture:
        texture = self.ctx.texture(size, 4, dtype="f2")
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        texture.repeat_x = texture.repeat_y = False
        return texture

    def bloom(self) -> None:
        """Fill the bloom chain from the scene: level 0 ends up holding the sum of all levels."""
        ctx = self.ctx
        source = self.scene_texture
        with render_state(ctx):
            for texture, framebuffer in self._levels:
                self._pass(self._downsample, source, framebuffer, texture.size)
                source = texture
        with render_state(ctx, moderngl.BLEND, blend_func=(moderngl.ONE, moderngl.ONE)):
            self._upsample["u_radius"].value = UPSAMPLE_RADIUS
            for (texture, _), (_, larger) in zip(
                reversed(self._levels[1:]), reversed(self._levels[:-1]), strict=True
            ):
                self._pass(self._upsample, texture, larger, larger.size, blend=True)

    def finish(
        self,
        target_fbo: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        exposure: float | Callable[[float], float],
        bloom_strength: float = DEFAULT_BLOOM_STRENGTH,
        tone_map: bool = True,
    ) -> float:
        """Resolve the scene into ``viewport`` of ``target_fbo``: bloom, exposure, ACES and sRGB
        encoding; with ``tone_map=False`` the scene's values are written as they are, clamped to
        [0, 1] (debug views). ``exposure`` may be a function of the scene's log-average
        luminance, metered first. Returns the exposure used."""
        if self.scene_framebuffer is None:
            raise RuntimeError("PostChain.finish before resize")
        use_bloom = tone_map and bloom_strength > 0
        metered = tone_map and callable(exposure)
        if use_bloom or metered:
            self.bloom()
        if callable(exposure):
            exposure = exposure(self.scene_luminance()) if metered else exposure(0.0)
        ctx = self.ctx
        program = self._resolve
        bloom_texture = self._levels[0][0]
        bloom_texture.use(location=1)
        set_uniform(program, "u_bloom", 1)
        set_uniform(program, "u_bloom_strength", float(bloom_strength) if use_bloom else 0.0)
        set_uniform(program, "u_bloom_normalisation", 1.0 / BLOOM_LEVELS)
        set_uniform(program, "u_exposure", float(exposure))
        set_uniform(program, "u_tone_map", bool(tone_map))
        saved_viewport = target_fbo.viewport
        try:
            with render_state(ctx):
                self._pass(program, self.scene_texture, target_fbo, viewport[2:], viewport[:2])
        finally:
            target_fbo.viewport = saved_viewport
        return float(exposure)

    def copy_depth(self, target_fbo: moderngl.Framebuffer, viewport) -> None:
        """The scene's depth into ``viewport`` of ``target_fbo``'s depth buffer (which must be
        the scene's size there), its colour untouched."""
        ctx = self.ctx
        saved_viewport = target_fbo.viewport
        flags = moderngl.DEPTH_TEST | moderngl.BLEND
        try:
            with render_state(ctx, flags, blend_func=(moderngl.ZERO, moderngl.ONE)):
                ctx.depth_func = "1"  # always: the depth is written, not tested
                self._pass(self._depth_copy, self.depth_texture, target_fbo, viewport[2:],
                           viewport[:2], blend=True)  # fmt: skip
        finally:
            ctx.depth_func = "<"
            target_fbo.viewport = saved_viewport

    def scene_luminance(self) -> float:
        """Log-average luminance of the scene (after ``bloom``, whose smallest level it reads)."""
        source = self._levels[-1][0]
        with render_state(self.ctx):
            self._pass(self._meter, source, self._meter_fbo, (METER_SIZE, METER_SIZE))
        top = int(np.log2(METER_SIZE))
        if self.wait_without_gil:
            build_mipmaps_without_gil(self._meter_texture)
            data = read_without_gil(self._meter_texture, level=top)
        else:
            self._meter_texture.build_mipmaps()
            data = self._meter_texture.read(level=top)
        log_mean = float(np.frombuffer(data, dtype=np.float32)[0])
        return float(np.exp(log_mean)) if np.isfinite(log_mean) else 0.0

    def _pass(self, program, source, framebuffer, size, offset=(0, 0), blend=False) -> None:
        if self.wait_without_gil:
            finish_without_gil()  # the draws into the source, which this pass would wait on
        source.use(location=0)
        set_uniform(program, "u_source", 0)
        set_uniform(program, "u_source_texel", (1.0 / source.size[0], 1.0 / source.size[1]))
        set_uniform(program, "u_viewport", (*(float(v) for v in offset), *(float(v) for v in size)))
        with drawing_into(self.ctx, framebuffer):
            self.ctx.viewport = (*offset, *size)
            draw_fullscreen(self.ctx, program, blend=blend)

    def _release_targets(self) -> None:
        for obj in (self.scene_framebuffer, self.scene_texture, self.depth_texture):
            if obj is not None:
                obj.release()
        for texture, framebuffer in self._levels:
            framebuffer.release()
            texture.release()
        self._levels = []
        self.scene_framebuffer = self.scene_texture = self.depth_texture = None
        self.size = None

    def release(self) -> None:
        self._release_targets()
        self._owned.release()
