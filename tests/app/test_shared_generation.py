"""One generation per edit, shared by the 2D preview and the 3D view; nothing for a hidden
view; a material built on uploaded grains is the material generated in place."""

from __future__ import annotations

import ctypes
import dataclasses
import gc
import os

import numpy as np
import pytest

from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from tests.app.test_view3d import TIMEOUT_MS, open_3d
from tests.gl_objects import live_gl_objects

pytestmark = pytest.mark.qt


def live_gl_objects_of(view) -> dict[str, int]:
    """Names of each kind of GL object alive in the view's context (the driver's own count)."""
    return view.call_in_context(live_gl_objects)


def gl_error_of(view) -> str:
    """The (then cleared) error state of the view's drawing context."""
    return view.gl_error()


def resident_kib() -> int:
    """Resident memory in use: Python's garbage collected and the C heap's free pages handed
    back first (glibc keeps them otherwise, in amounts that vary from run to run by several
    percent and would hide or fake a leak)."""
    gc.collect()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    with open(f"/proc/{os.getpid()}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def uploaded_normal_height(view) -> np.ndarray:
    grains = view.material._grains
    data = view.call_in_context(lambda ctx: grains.normal_height.read())
    return np.frombuffer(data, np.float32).reshape(grains.size, grains.size, 4)


def wait_generated(window, qtbot) -> None:
    qtbot.waitUntil(lambda: not window.regenerator.busy, timeout=TIMEOUT_MS)


def test_one_generation_feeds_both_views(window, qtbot):
    panel = open_3d(window, qtbot)
    view = panel.view
    generations = window.regenerator.generations
    uploads = view.grain_uploads

    window.model.edit("generation.threshold", 0.4)
    wait_generated(window, qtbot)
    qtbot.waitUntil(lambda: view.grain_uploads > uploads, timeout=TIMEOUT_MS)

    assert window.regenerator.generations == generations + 1
    assert view.grain_uploads == uploads + 1
    assert view.grains_generation == window.model.preset.generation
    # The 3D view's grains are the 2D preview's tile, and its context never generated any.
    textures = window.preview.textures
    uploaded = uploaded_normal_height(view)
    assert np.array_equal(uploaded[..., :3], textures.normal)
    assert np.array_equal(uploaded[..., 3], textures.height)
    assert "sand_generator" not in (view.call_in_context(lambda ctx: ctx.extra) or {})
    qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)
    np.testing.assert_allclose(
        view.material.average_albedo, textures.albedo.mean(axis=(0, 1)), rtol=0.02
    )


def test_a_hidden_3d_view_does_no_work(window, qtbot):
    panel = open_3d(window, qtbot)
    view = panel.view
    qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)
    window.preview.tabs.setCurrentIndex(0)  # back to the albedo map
    frames, uploads = view.frames, view.grain_uploads
    generations = window.regenerator.generations

    window.model.edit("generation.seed", 5)
    wait_generated(window, qtbot)
    window.model.edit("shading.facet_roughness", 0.5)
    qtbot.wait(400)

    assert window.regenerator.generations == generations + 1  # the 2D preview's tile
    assert (view.frames, view.grain_uploads) == (frames, uploads)

    window.preview.show_3d()
    qtbot.waitUntil(lambda: view.grain_uploads == uploads + 1, timeout=TIMEOUT_MS)
    qtbot.waitUntil(lambda: view.frames > frames, timeout=TIMEOUT_MS)
    assert window.regenerator.generations == generations + 1  # showing it generated nothing
    assert view.material.preset == window.model.preset


def test_a_generation_edit_is_drawn_once_with_its_own_grains(window, qtbot):
    panel = open_3d(window, qtbot)
    view = panel.view
    qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)
    drawn_with = []

    def record(_timings):
        drawn_with.append(view.grains_generation == window.model.preset.generation)

    view.rendered.connect(record)
    try:
        window.model.edit("generation.threshold", 0.45)
        wait_generated(window, qtbot)
        qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)
    finally:
        view.rendered.disconnect(record)
    # A frame before the tile arrived would show the old grains as if they were the edit.
    assert drawn_with and all(drawn_with), drawn_with


def test_undo_shows_the_cached_tile_without_generating(window, qtbot):
    before = window.preview.textures
    window.model.edit("generation.roundness", 0.6)
    wait_generated(window, qtbot)
    generations = window.regenerator.generations

    window.model.undo_stack.undo()

    assert not window.regenerator.busy
    assert window.regenerator.generations == generations
    assert window.preview.textures is before


def test_a_material_on_uploaded_grains_equals_one_generated_in_place(gl_clean):
    preset = Preset().replace(**{"generation.seed": 11, "shading.clear_grains": 0.5})
    in_place = SandMaterial(gl_clean, 128)
    uploaded = SandMaterial(gl_clean, 128)
    try:
        in_place.update(preset)
        uploaded.update(preset, grains=generate(preset, 128, ctx=gl_clean))
        for name in ("albedo", "glint_moments", "spread_moments", "hole_moments"):
            assert getattr(in_place, name).read() == getattr(uploaded, name).read(), name
        np.testing.assert_array_equal(in_place.average_albedo, uploaded.average_albedo)
        assert uploaded.grains_generation == preset.generation
        with pytest.raises(ValueError, match="256².*128²"):
            uploaded.update(preset, grains=generate(preset, 256, ctx=gl_clean))
        anonymous = dataclasses.replace(generate(preset, 128, ctx=gl_clean), generation=None)
        with pytest.raises(ValueError, match="which generation"):
            uploaded.update(preset, grains=anonymous)
    finally:
        in_place.release()
        uploaded.release()


def test_grains_keep_their_own_colours_under_a_newer_preset(gl_clean):
    # A tile arriving after a further generation edit is shaded with the newest preset but
    # coloured by the generation that made it: no grains drawn in another sand's colours.
    old = Preset().replace(**{"generation.seed": 3})
    newer = old.replace(**{"generation.base_color": "#e01a1a", "shading.clear_grains": 0.7})
    late, direct = SandMaterial(gl_clean, 128), SandMaterial(gl_clean, 128)
    try:
        late.update(newer, grains=generate(old, 128, ctx=gl_clean))
        direct.update(old.replace(**{"shading.clear_grains": 0.7}))
        assert late.preset == newer and late.grains_generation == old.generation
        assert late.albedo.read() == direct.albedo.read()
        assert late.glint_moments.read() == direct.glint_moments.read()
    finally:
        late.release()
        direct.release()


def test_moving_frames_draw_at_reduced_resolution_then_refine(window, qtbot):
    panel = open_3d(window, qtbot)
    view = panel.view
    qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)
    full_frames = view.full_frames

    panel.view.orbited.emit(10.0, 0.0)
    qtbot.waitUntil(lambda: view.last_timings["scale"] < 1.0, timeout=TIMEOUT_MS)
    moving = pixel_image(view)

    qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)
    assert view.full_frames == full_frames + 1
    qtbot.waitUntil(lambda: "full resolution in" in panel.status.text(), timeout=TIMEOUT_MS)
    assert "bands" in panel.status.text()
    assert moving.max() > 40  # the scaled-up frame shows the desert, not black


def pixel_image(view) -> np.ndarray:
    from tests.app.test_view3d import pixels

    return pixels(view.grab().toImage())


@pytest.mark.slow
def test_a_thousand_edits_leave_gl_objects_and_memory_flat(window, qtbot):
    panel = open_3d(window, qtbot)
    view = panel.view
    model = window.model
    fields = ("generation.seed", "shading.clear_grains", "shading.facet_roughness")

    def edit_many(count: int, offset: int) -> None:
        for i in range(count):
            path = fields[i % len(fields)]
            value = {
                "generation.seed": 1000 + offset + i,
                "shading.clear_grains": 0.05 + (i % 10) * 0.1,
                "shading.facet_roughness": 0.05 + 0.02 * (i % 40),
            }[path]
            model.edit(path, value)
            if i % 250 == 125:
                # A new tile size makes the view replace its material.
                window.preview.size_combo.setCurrentIndex(
                    1 - window.preview.size_combo.currentIndex()
                )
                wait_generated(window, qtbot)
                qtbot.waitUntil(
                    lambda: view.material.texture_size == window.preview.preview_size,
                    timeout=TIMEOUT_MS,
                )
            if i % 10 == 0:
                qtbot.wait(1)  # frames, generation bands and uploads happen
        wait_generated(window, qtbot)
        qtbot.waitUntil(
            lambda: view.grains_generation == model.preset.generation, timeout=TIMEOUT_MS
        )
        qtbot.waitUntil(lambda: view.at_rest, timeout=TIMEOUT_MS)

    # Both tile sizes twice: caches, the driver's compiled state and the heap reach their
    # working size.
    edit_many(1000, 0)
    objects, memory = live_gl_objects_of(view), resident_kib()
    gl_error_of(view)  # reads and clears what the context's creation left (Qt's or the driver's)
    assert objects["Texture"] > 10 and objects["Program"] > 3  # the count sees them
    # Two more rounds: a leak raises both, while the driver's heap moves a few percent either way
    # from one measurement to the next (one round alone crossed 5 % in about one run in six).
    edit_many(1000, 10_000)
    second = resident_kib()
    edit_many(1000, 20_000)
    third = resident_kib()
    assert min(second, third) < memory * 1.05, (memory, second, third)
    assert gl_error_of(view) == "GL_NO_ERROR"
    assert live_gl_objects_of(view) == objects
