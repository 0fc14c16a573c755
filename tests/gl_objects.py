"""Counting the GL objects alive in a context, for tests that check nothing is left behind."""

from __future__ import annotations

import ctypes

import moderngl

_GL = ctypes.CDLL("libGL.so.1")
_KINDS = ("Texture", "Buffer", "Framebuffer", "Renderbuffer", "VertexArray", "Program", "Shader")
_VERTEX = "#version 330\nvoid main() { gl_Position = vec4(0.0); }"


def live_gl_objects(ctx: moderngl.Context) -> dict[str, int]:
    """Names alive per kind of GL object (the driver's own count), scanned to well past the
    newest name of each kind."""
    texture = ctx.texture((1, 1), 4)
    program = ctx.program(vertex_shader=_VERTEX)
    probes = (
        texture,
        ctx.buffer(reserve=4),
        ctx.framebuffer([texture]),
        ctx.vertex_array(program, []),
        program,
    )
    limit = 2 * max(probe.glo for probe in probes) + 64
    for probe in reversed(probes):
        probe.release()
    # A deleted program stays alive while it is the current one.
    _GL.glUseProgram(0)
    counts = {}
    for kind in _KINDS:
        is_kind = getattr(_GL, f"glIs{kind}")
        is_kind.restype = ctypes.c_ubyte
        counts[kind] = sum(1 for name in range(1, limit) if is_kind(name))
    return counts
