"""The integer hash pins every user's sand across versions: fixed values, and GLSL equals numpy.

If a change to the hash is intended, every existing preset's sand changes: regenerate the pinned
values below with the snippet in each test's comment, and say so in the release notes.
"""

from __future__ import annotations

import re

import moderngl
import numpy as np
import pytest

from sand_editor.generator.noise import NoiseConstants, glint_value, lowbias32, point_words
from sand_editor.gl import draw_fullscreen, fullscreen_program, release_program
from sand_editor.preset import Preset
from sand_editor.resources import shader_source

MASK = 0xFFFFFFFF


def lowbias32_python(x: int) -> int:
    """Wellons' lowbias32 in plain Python integers, independent of numpy's wrap-around."""
    x ^= x >> 16
    x = (x * 0x7FEB352D) & MASK
    x ^= x >> 15
    x = (x * 0x846CA68B) & MASK
    return x ^ (x >> 16)


PINNED_LOWBIAS32 = {
    0: 0x0,
    1: 0x688990C0,
    270: 0xBEAD9D2B,
    0xDEADBEEF: 0xE628C683,
    0xFFFFFFFF: 0x6768824A,
}


def test_lowbias32_pinned_values():
    # print(list(map(hex, map(int, lowbias32(np.array([...], dtype=np.uint32))))))
    keys = np.array(list(PINNED_LOWBIAS32), dtype=np.uint32)
    assert lowbias32(keys).dtype == np.uint32
    assert [int(v) for v in lowbias32(keys)] == list(PINNED_LOWBIAS32.values())
    assert [lowbias32_python(int(k)) for k in keys] == list(PINNED_LOWBIAS32.values())


def test_lowbias32_matches_python_integers_on_random_words():
    words = np.random.default_rng(32).integers(0, 2**32, 2000, dtype=np.uint64).astype(np.uint32)
    assert [int(v) for v in lowbias32(words)] == [lowbias32_python(int(w)) for w in words]


def test_point_words_pinned_values():
    # The default preset (seed 270, period 36): both points of cells (0,0), (35,35), (5,7) of
    # layer 3. print([[hex(int(w)) for w in r] for r in point_words(nc, cx, cy, 3)])
    nc = NoiseConstants.from_generation(Preset().generation)
    assert nc.seed_key == 3199049003
    words = point_words(nc, np.array([0, 35, 5]), np.array([0, 35, 7]), 3)
    assert words.dtype == np.uint32
    expected = [[0xB282CAB9, 0x72E4374A], [0x9AB34F5A, 0xE0DDE908], [0xEA6600D7, 0x5883128F]]
    assert words.tolist() == expected


def test_glint_uses_the_top_byte():
    words = np.array([0x00FFFFFF, 0x01000000, 0xFF000000], dtype=np.uint32)
    np.testing.assert_array_equal(glint_value(words), [0.0, 1 / 256, 255 / 256])


def test_seed_key_is_warning_free():
    # lowbias32 on a 0-d input once warned on its intended uint32 wrap (numpy scalar overflow).
    nc = NoiseConstants.from_generation(Preset().generation)
    with np.errstate(all="raise"):
        assert nc.seed_key == lowbias32_python(270)


HASH_SHADER = """#version 330 core
uniform uint u_base;
layout(location = 0) out uvec4 out_hash;
{lowbias32}
void main() {{
    ivec2 t = ivec2(gl_FragCoord.xy);
    uint x = u_base + uint(t.y * 64 + t.x) * 4u;
    out_hash = uvec4(lowbias32(x), lowbias32(x + 1u), lowbias32(x + 2u), lowbias32(x + 3u));
}}
"""


@pytest.mark.gl
@pytest.mark.parametrize("base", [0, 0x7FFFC000, 0xFFFFC000])
def test_glsl_lowbias32_equals_numpy(gl_ctx, base, monkeypatch):
    # The GLSL function every program shares (common.glsl), over 16384 words.
    source = shader_source("common.glsl")
    function = re.search(r"uint lowbias32\(uint x\) \{.*?\n\}", source, re.S)
    assert function, "common.glsl has no lowbias32"
    monkeypatch.setattr(
        "sand_editor.gl.shader_source",
        lambda name: (
            HASH_SHADER.format(lowbias32=function.group(0))
            if name == "test_hash"
            else shader_source(name)
        ),
    )
    program = fullscreen_program(gl_ctx, "test_hash")
    texture = gl_ctx.texture((64, 64), 4, dtype="u4")
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    fbo = gl_ctx.framebuffer(color_attachments=[texture])
    try:
        fbo.use()
        gl_ctx.viewport = (0, 0, 64, 64)
        program["u_base"].value = base
        draw_fullscreen(gl_ctx, program)
        table = np.frombuffer(texture.read(), dtype=np.uint32)
    finally:
        gl_ctx.detect_framebuffer(0).use()
        fbo.release()
        texture.release()
        release_program(program)
    keys = (np.uint64(base) + np.arange(table.size, dtype=np.uint64)).astype(np.uint32)
    np.testing.assert_array_equal(table, lowbias32(keys))
