"""The GLSL generator: renders the grain textures with moderngl, headless or in any context."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import moderngl
import numpy as np

from sand_editor.generator._textures import SandTextures
from sand_editor.generator.noise import SHADER_DEFINES, NoiseConstants, grain_appearance
from sand_editor.gl import (
    draw_fullscreen,
    drawing_into,
    finish_without_gil,
    fullscreen_program,
    release_program,
)

READ_BAND_ROWS = 256


@dataclass
class GpuSandTextures:
    """Grain textures resident on the GPU, as the renderer samples them.

    ``normal_height``: RGBA32F (normal xyz, height); ``layer_grain``: RG32UI (owning layer + 1,
    0 in gaps; the grain word, from which colour and glint follow for any palette).
    """

    size: int
    normal_height: moderngl.Texture
    layer_grain: moderngl.Texture
    framebuffer: moderngl.Framebuffer

    @classmethod
    def allocate(cls, ctx: moderngl.Context, size: int) -> GpuSandTextures:
        """Empty grain textures of size×size on ``ctx``, with their framebuffer."""
        nh = ctx.texture((size, size), 4, dtype="f4")
        lg = ctx.texture((size, size), 2, dtype="u4")
        for tex in (nh, lg):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return cls(size, nh, lg, ctx.framebuffer(color_attachments=[nh, lg]))

    def read(self, constants: NoiseConstants, generation=None) -> SandTextures:
        """Copy the textures to numpy arrays (a GPU → CPU read-back) and colour the grains.

        ``generation``, the parameters ``constants`` came from, travels with the textures.
        """
        n = self.size
        # The wait for the draws leaves Python free for other threads; the copies hold it.
        finish_without_gil()
        # Read and coloured a band of rows at a time, straight into the arrays kept: a 4096²
        # tile's whole read-back and its colouring's temporaries would take another gigabyte.
        nh = np.empty((n, n, 4), np.float32)
        layer = np.empty((n, n), np.int8)
        grain = np.empty((n, n), np.uint32)
        albedo = np.empty((n, n, 3), np.float32)
        glint = np.empty((n, n), np.float32)
        lg = np.empty((min(n, READ_BAND_ROWS), n, 2), np.uint32)
        for start in range(0, n, READ_BAND_ROWS):
            rows = min(READ_BAND_ROWS, n - start)
            viewport = (0, start, n, rows)
            self.framebuffer.read_into(nh, viewport, 4, attachment=0, dtype="f4",
                                       write_offset=start * n * nh.itemsize * 4)  # fmt: skip
            self.framebuffer.read_into(lg, viewport, 2, attachment=1, dtype="u4")
            band = slice(start, start + rows)
            layer[band] = lg[:rows, :, 0].astype(np.int8) - np.int8(1)
            grain[band] = lg[:rows, :, 1]
            albedo[band], glint[band] = grain_appearance(constants, layer[band], grain[band])
        return SandTextures(
            albedo=albedo,
            # Views into the one read-back buffer: copying 16 MB at 1024² would cost more than
            # anything a caller does with strided arrays.
            normal=nh[..., :3],
            height=nh[..., 3],
            glint=glint,
            layer=layer,
            grain_id=grain,
            generation=generation,
        )

    def copy_from(self, other: GpuSandTextures) -> None:
        """Make these textures hold ``other``'s grains (same context and size), on the GPU."""
        if other.size != self.size:
            raise ValueError(f"grains are {other.size}², these textures {self.size}²")
        ctx = self.framebuffer.ctx
        pairs = ((self.normal_height, other.normal_height), (self.layer_grain, other.layer_grain))
        for target, source in pairs:
            # A blit between framebuffers of one attachment each: copying straight into a
            # texture does not take float or integer formats.
            read, draw = ctx.framebuffer([source]), ctx.framebuffer([target])
            try:
                ctx.copy_framebuffer(draw, read)
            finally:
                read.release()
                draw.release()

    def release(self) -> None:
        ctx = self.framebuffer.ctx
        for obj in (self.framebuffer, self.normal_height, self.layer_grain):
            obj.release()
        _draw_elsewhere(ctx)


def _draw_elsewhere(ctx: moderngl.Context) -> None:
    """Clear a 1×1 framebuffer: a software rasterizer (Mesa's llvmpipe) keeps the textures of
    the last framebuffer it drew into until it draws into another, 384 MB for a 4096² tile."""
    texture = ctx.texture((1, 1), 4)
    framebuffer = ctx.framebuffer(color_attachments=[texture])
    try:
        with drawing_into(ctx, framebuffer):
            framebuffer.clear()
    finally:
        framebuffer.release()
        texture.release()


class GLGenerator:
    """Generates grain textures in a moderngl context (compiles its program once)."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self.program = fullscreen_program(ctx, "sand_generate.frag", SHADER_DEFINES)

    def _set_uniforms(self, nc: NoiseConstants, size: int) -> None:
        p = self.program
        p["u_size"].value = size
        p["u_period"].value = nc.period
        p["u_layers"].value = nc.layers
        p["u_seed_key"].value = nc.seed_key
        p["u_threshold"].value = nc.threshold
        p["u_grain_reach2"].value = nc.grain_reach2
        p["u_jitter"].value = nc.jitter

    def allocate(self, size: int) -> GpuSandTextures:
        return GpuSandTextures.allocate(self.ctx, size)

    def render(
        self,
        generation: NoiseConstants,
        size: int,
        target: GpuSandTextures | None = None,
        rows: tuple[int, int] | None = None,
    ) -> GpuSandTextures:
        """Render the grain textures at size×size; returns them on the GPU.

        ``rows`` (start, stop) renders only that band of rows into ``target``, so a large texture
        can be produced in short steps that never hold the caller for long.
        """
        nc = generation
        target = target if target is not None else self.allocate(size)
        if target.size != size:
            raise ValueError(f"target textures are {target.size}², asked for {size}²")
        start, stop = rows if rows is not None else (0, size)
        self._set_uniforms(nc, size)
        with drawing_into(self.ctx, target.framebuffer):
            # gl_FragCoord counts from the framebuffer's origin, so a band is just a viewport.
            self.ctx.viewport = (0, start, size, stop - start)
            draw_fullscreen(self.ctx, self.program)
        return target

    def render_in_bands(
        self, generation: NoiseConstants, target: GpuSandTextures, band_rows: int
    ) -> Iterator[tuple[int, int]]:
        """Draw ``target`` band by band, ``band_rows`` rows at a time, yielding each band's rows
        (start, stop) once it is drawn (not waited for): the one band loop of every caller,
        which waits, yields to its event loop or stops between bands as it needs."""
        size = target.size
        for start in range(0, size, band_rows):
            rows = (start, min(size, start + band_rows))
            self.render(generation, size, target, rows=rows)
            yield rows

    def release(self) -> None:
        """Release the program (a generator of its own; ``gl_generator``'s lives with its
        context)."""
        release_program(self.program)
