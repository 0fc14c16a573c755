"""Waiting for GL without Python's lock: other Python threads keep running while this one waits
for its draws, and what the waits produce matches moderngl's own calls."""

from __future__ import annotations

import sys
import threading

import numpy as np
import pytest

from sand_editor.gl import (
    build_mipmaps_without_gil,
    drawing_into,
    finish_without_gil,
    read_without_gil,
    shader_text,
    standalone_context,
)

HEAVY = """#version 330
uniform int u_steps;
out vec4 colour;
void main() {
    vec2 p = gl_FragCoord.xy;
    float a = 0.0;
    for (int i = 0; i < u_steps; ++i) {
        a = fract(sin(a * 12.9898 + p.x * 78.233 + float(i)) * 43758.5453 + p.y);
    }
    colour = vec4(a, 0.0, 0.0, 1.0);
}
"""


@pytest.fixture
def ctx(gl_ctx):
    """The headless context, current again even where a window's context was made current
    on this thread by an earlier test; no GL error pending before or after."""
    assert standalone_context() is gl_ctx
    assert gl_ctx.error == "GL_NO_ERROR"
    yield gl_ctx
    assert gl_ctx.error == "GL_NO_ERROR"


def _program(ctx):
    return ctx.program(vertex_shader=shader_text("fullscreen.vert"), fragment_shader=HEAVY)


def _progress_of_another_thread_during(ctx, wait) -> int:
    """How many times another Python thread got to run while ``wait`` waited for a long draw.

    The interpreter is told not to switch threads on its own for the test (a 30 s interval),
    and the other thread gives the lock back at every step: it runs only while this thread
    gives the lock away, so a wait that keeps the lock leaves its count exactly where it was.
    """
    program = _program(ctx)
    program["u_steps"].value = 1500
    target = ctx.texture((256, 256), 4, dtype="f4")
    framebuffer = ctx.framebuffer([target])
    triangle = ctx.vertex_array(program, [])
    count = [0]
    running, stop = threading.Event(), threading.Event()

    def spin():
        running.set()
        while not stop.wait(0.0005):
            count[0] += 1

    interval = sys.getswitchinterval()
    thread = threading.Thread(target=spin, daemon=True)
    try:
        thread.start()
        running.wait()
        sys.setswitchinterval(30.0)
        with drawing_into(ctx, framebuffer):
            ctx.viewport = (0, 0, 256, 256)
            triangle.render(vertices=3)
            before = count[0]
            wait()
            after = count[0]
    finally:
        sys.setswitchinterval(interval)
        stop.set()
        thread.join()
        for obj in (triangle, framebuffer, target, program):
            obj.release()
    return after - before


def test_another_thread_runs_while_this_one_waits_for_a_long_draw(ctx):
    assert _progress_of_another_thread_during(ctx, finish_without_gil) > 0


def test_moderngl_finish_keeps_other_threads_waiting(ctx):
    """The reason for the helper: the same wait through moderngl holds the lock throughout.
    (The released wait lets the other thread count about 290 times; one count may still land
    at the wait's edge on a loaded machine, which the suite's two processes make it.)"""
    assert _progress_of_another_thread_during(ctx, ctx.finish) <= 1


def test_mipmaps_and_read_back_match_moderngl(ctx):
    rng = np.random.default_rng(7)
    pixels = rng.random((64, 64, 4), dtype=np.float32)
    ours, theirs = (ctx.texture((64, 64), 4, pixels.tobytes(), dtype="f4") for _ in range(2))
    try:
        for texture in (ours, theirs):
            texture.build_mipmaps()
        replaced = rng.random((64, 64, 4), dtype=np.float32)
        for texture in (ours, theirs):
            texture.write(replaced.tobytes())
        theirs.build_mipmaps()
        build_mipmaps_without_gil(ours)
        for level in range(7):
            a = np.frombuffer(read_without_gil(ours, level=level), dtype=np.float32)
            b = np.frombuffer(theirs.read(level=level), dtype=np.float32)
            np.testing.assert_array_equal(a, b)
        top = np.frombuffer(read_without_gil(ours, level=6), dtype=np.float32)
        np.testing.assert_allclose(top, replaced.reshape(-1, 4).mean(axis=0), rtol=1e-4)
        assert not np.allclose(top, pixels.reshape(-1, 4).mean(axis=0), rtol=1e-4)
    finally:
        ours.release()
        theirs.release()
