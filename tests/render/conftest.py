"""A renderer with a small sand material, shared by the renderer tests (building one compiles
the material's programs, which is the slow part on a software rasterizer)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def sand_renderer(gl_ctx):
    from sand_editor.preset import Preset
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer

    material = SandMaterial(gl_ctx, texture_size=64)
    material.update(Preset())
    renderer = SandRenderer(gl_ctx)
    renderer.set_material(material)
    yield renderer
    renderer.release()
    material.release()
