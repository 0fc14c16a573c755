"""Every owner of a fullscreen program gives back all it made, its vertex array included."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.bench._reference_port import ReferenceParams, ReferencePort
from sand_editor.generator import gl_generator
from sand_editor.generator._gl import GLGenerator
from sand_editor.generator.noise import NoiseConstants
from sand_editor.gl import draw_fullscreen, drawing_into, shader_text
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from sand_editor.render.post import PostChain
from tests.gl_objects import live_gl_objects


def material(ctx):
    owner = SandMaterial(ctx, 64)
    owner.update(Preset())
    return owner


def post_chain(ctx):
    owner = PostChain(ctx)
    owner.resize(16, 8)
    target = ctx.texture((16, 8), 4)
    framebuffer = ctx.framebuffer([target])
    owner.finish(framebuffer, (0, 0, 16, 8), exposure=1.0)
    framebuffer.release()
    target.release()
    return owner


def generator(ctx):
    owner = GLGenerator(ctx)
    owner.render(NoiseConstants.from_generation(Preset().generation), 64).release()
    return owner


def reference_port(ctx):
    owner = ReferencePort(ctx)
    owner.render(ReferenceParams.from_preset(Preset()), 32)
    return owner


@pytest.mark.parametrize("make", [material, post_chain, generator, reference_port])
def test_an_owner_of_fullscreen_programs_releases_all_it_made(gl_clean, make):
    # The context's own generator, made and drawn once, lives with the context.
    gl_generator(gl_clean).render(NoiseConstants.from_generation(Preset().generation), 64).release()
    before = live_gl_objects(gl_clean)
    owner = make(gl_clean)
    assert live_gl_objects(gl_clean)["VertexArray"] > before["VertexArray"]  # it drew
    owner.release()
    assert live_gl_objects(gl_clean) == before


def test_a_new_program_draws_with_its_own_vertex_array(gl_clean):
    from sand_editor.gl import release_program

    def solid(red: float):
        return gl_clean.program(
            vertex_shader=shader_text("fullscreen.vert"),
            fragment_shader=f"#version 330\nout vec4 colour;\n"
            f"void main() {{ colour = vec4({red}, 0.0, 0.0, 1.0); }}",
        )

    texture = gl_clean.texture((4, 4), 4)
    framebuffer = gl_clean.framebuffer([texture])
    before = live_gl_objects(gl_clean)
    try:
        for red in (0.25, 0.75, 0.5):
            program = solid(red)
            with drawing_into(gl_clean, framebuffer):
                gl_clean.viewport = (0, 0, 4, 4)
                draw_fullscreen(gl_clean, program)
            release_program(program)
            release_program(program)  # twice is harmless
            pixels = np.frombuffer(framebuffer.read(components=4), np.uint8).reshape(16, 4)
            assert np.all(pixels[:, 0] == round(red * 255)), (red, pixels[0])
        assert live_gl_objects(gl_clean) == before
    finally:
        framebuffer.release()
        texture.release()


def test_drawing_into_after_the_bound_framebuffer_was_released(gl_clean):
    # A framebuffer released while bound stays the context's current one, with an invalid
    # handle: drawing into another must not try to bind it again afterwards.
    # (Made first: moderngl rebinds the current framebuffer after making one.)
    texture = gl_clean.texture((4, 4), 4)
    framebuffer = gl_clean.framebuffer([texture])
    stale_texture = gl_clean.texture((4, 4), 4)
    stale = gl_clean.framebuffer([stale_texture])
    stale.use()
    stale.release()
    stale_texture.release()
    try:
        with drawing_into(gl_clean, framebuffer):
            framebuffer.clear(1.0, 0.0, 0.0, 1.0)
        assert texture.read()[:4] == b"\xff\x00\x00\xff"
    finally:
        framebuffer.release()
        texture.release()


def test_gl_objects_releases_everything_it_kept_once_last_made_first(gl_clean):
    from sand_editor.gl import GLObjects, fullscreen_program

    before = live_gl_objects(gl_clean)
    with GLObjects() as owned:
        texture = owned.keep(gl_clean.texture((8, 8), 4))
        framebuffer = owned.keep(gl_clean.framebuffer([texture]))
        program = owned.keep(fullscreen_program(gl_clean, "post.glsl", {"METER": 1}))
        with drawing_into(gl_clean, framebuffer):
            draw_fullscreen(gl_clean, program)  # makes the program's vertex array
        assert live_gl_objects(gl_clean)["VertexArray"] == before["VertexArray"] + 1
    assert live_gl_objects(gl_clean) == before
    owned.release()  # twice is harmless
    assert live_gl_objects(gl_clean) == before


def test_render_state_sets_exactly_its_flags_and_leaves_none_behind(gl_clean):
    import moderngl

    from sand_editor.gl import release_program, render_state

    program = gl_clean.program(
        vertex_shader=shader_text("fullscreen.vert"),
        fragment_shader="#version 330\nout vec4 c;\nvoid main() { c = vec4(0.25, 0, 0, 1); }",
    )
    texture = gl_clean.texture((4, 4), 4)
    framebuffer = gl_clean.framebuffer([texture])

    def red_after_two_draws() -> int:
        with drawing_into(gl_clean, framebuffer):
            gl_clean.viewport = (0, 0, 4, 4)
            framebuffer.clear()
            for _ in range(2):
                draw_fullscreen(gl_clean, program, blend=True)  # keeps whatever blending is on
        return int(np.frombuffer(framebuffer.read(components=4), np.uint8)[0])

    try:
        gl_clean.enable(moderngl.BLEND)  # as a host leaves it
        gl_clean.blend_func = moderngl.ONE, moderngl.ONE
        with render_state(gl_clean):
            assert red_after_two_draws() == 64, "no blending inside a plain render state"
        with render_state(gl_clean, moderngl.BLEND, blend_func=(moderngl.ONE, moderngl.ONE)):
            assert red_after_two_draws() == 128, "adding blend inside its block"
        assert red_after_two_draws() == 64, "and none after it"
    finally:
        release_program(program)
        framebuffer.release()
        texture.release()
