"""A renderer with a small sand material, shared by the renderer tests (building one compiles
the material's programs, which is the slow part on a software rasterizer)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest


@contextmanager
def renderer_with_material(ctx, texture_size: int = 64) -> Iterator:
    """A ``SandRenderer`` drawing the default preset's material, released after the block."""
    from sand_editor.preset import Preset
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    material = SandMaterial(ctx, texture_size=texture_size)
    material.update(Preset())
    renderer = SandRenderer(ctx)
    renderer.set_material(material)
    try:
        yield renderer
    finally:
        renderer.release()
        material.release()


@pytest.fixture(scope="session")
def sand_renderer(gl_ctx):
    with renderer_with_material(gl_ctx) as renderer:
        yield renderer


@pytest.fixture(scope="module")
def fine_sand_renderer(gl_ctx):
    """The default sand at 512² texels: its grains a few pixels wide in 160×90 views up close."""
    with renderer_with_material(gl_ctx, texture_size=512) as renderer:
        yield renderer
