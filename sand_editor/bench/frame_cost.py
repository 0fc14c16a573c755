"""What a frame costs, for ``sand-editor bench render``: the material's parts per megapixel on the
probe, with and without skipping negligible close-range work, and a stereo frame through the whole
renderer."""

from __future__ import annotations

import statistics
import time

import moderngl

from sand_editor.bench.probe import MaterialProbe
from sand_editor.render.material import CLOSE_CUTOFF, SandMaterial
from sand_editor.render.request import FrameRequest

STEREO_EYE = (1832, 1920)


def material_costs(probe: MaterialProbe, repeats: int) -> dict:
    """Per-megapixel costs of the parts of a frame, and what skipping negligible close-range
    work saves, on a view whose far half is past the blend (medians of ``repeats`` frames)."""
    material = probe.material
    distance = 4.0
    pitch_view = {}
    for name, mode, cutoff in (
        ("close", "close", 2.0),
        ("far", "far", 2.0),
        ("full_without_skip", "full", 2.0),
        ("full", "full", CLOSE_CUTOFF),
    ):
        material.close_cutoff = cutoff
        probe.glint_filter = "ours"
        camera = probe.camera(distance, pitch_deg=12.0)
        times = [probe.render(camera, mode)[1] for _ in range(repeats)]
        pitch_view[name] = statistics.median(times)
    material.close_cutoff = CLOSE_CUTOFF
    megapixels = probe.width * probe.height / 1e6
    per_mp = {k: v / megapixels for k, v in pitch_view.items()}
    per_mp["skip_saving"] = 1.0 - pitch_view["full"] / pitch_view["full_without_skip"]
    return per_mp


def stereo_cost(ctx: moderngl.Context, material: SandMaterial, scale: float, repeats: int) -> dict:
    """A stereo frame through the whole renderer at ``scale`` × 1832×1920 per eye (median of
    ``repeats`` frames after one to warm up)."""
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.renderer import SandRenderer
    from sand_editor.render.sky import sky_at

    width, height = (max(16, int(s * scale)) for s in STEREO_EYE)
    renderer = SandRenderer(ctx)
    renderer.set_material(material)
    sky = sky_at(10.0)
    target = ctx.framebuffer([ctx.texture((2 * width, height), 4)])
    left = camera_at_distance(2.0, 30.0, width / height, target_xz=(-0.032, 0.0))
    right = camera_at_distance(2.0, 30.0, width / height, target_xz=(0.032, 0.0))

    def frame():
        renderer.render(target, FrameRequest(left, sky, viewport=(0, 0, width, height)))
        renderer.render(target, FrameRequest(right, sky, viewport=(width, 0, width, height)))
        ctx.finish()

    frame()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        frame()
        times.append((time.perf_counter() - start) * 1e3)
    ms = statistics.median(times)
    megapixels = 2 * width * height / 1e6
    full_megapixels = 2 * STEREO_EYE[0] * STEREO_EYE[1] / 1e6
    return {
        "eye_size": [width, height],
        "ms": ms,
        "ms_per_megapixel": ms / megapixels,
        "estimated_full_size_ms": ms / megapixels * full_megapixels,
    }
