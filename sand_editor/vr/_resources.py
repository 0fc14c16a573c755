"""What a long session holds: live GL objects of the drawing context and the process's memory,
for the report (a soak test checks both stay flat)."""

from __future__ import annotations

import os

import moderngl

_KINDS = ("Buffer", "Texture", "Framebuffer", "VertexArray", "Program", "Shader")


def gl_object_counts(ctx: moderngl.Context) -> dict[str, int]:
    """Names alive per kind of GL object, found with ``glIs*`` up to beyond the newest name
    (drivers hand out names in increasing order and reuse freed ones)."""
    from OpenGL import GL

    buffer = ctx.buffer(reserve=4)
    texture = ctx.texture((1, 1), 1)
    limit = 2 * max(buffer.glo, texture.glo, 256)
    buffer.release()
    texture.release()
    counts = {}
    for kind in _KINDS:
        test = getattr(GL, f"glIs{kind}")
        counts[kind.lower()] = sum(1 for name in range(1, limit) if test(name))
    return counts


def resident_mb() -> float:
    """Resident memory of this process in MiB."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
