"""One headless frame of the desert, written to a PNG: ``sand-editor render``."""

from __future__ import annotations

import io
import math
import time
from pathlib import Path

from PIL import Image

from sand_editor.files import check_regular_target, write_atomic
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.material import SandMaterial
from sand_editor.render.modes import check_mode
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import parse_time, sky_at
from sand_editor.render.still import check_samples
from sand_editor.view import MAX_DISTANCE_M, MAX_PITCH_DEG, MIN_DISTANCE_M, MIN_PITCH_DEG


def check_view(distance_m: float, pitch_deg: float) -> None:
    if not (math.isfinite(distance_m) and MIN_DISTANCE_M <= distance_m <= MAX_DISTANCE_M):
        raise ValueError(
            f"distance {distance_m} m is out of range; allowed {MIN_DISTANCE_M} to {MAX_DISTANCE_M}"
        )
    if not (math.isfinite(pitch_deg) and MIN_PITCH_DEG <= pitch_deg <= MAX_PITCH_DEG):
        raise ValueError(
            f"pitch {pitch_deg}° is out of range; allowed {MIN_PITCH_DEG:g} to {MAX_PITCH_DEG:g} "
            "degrees"
        )


def render_frame(
    preset: Preset,
    out: Path,
    size: tuple[int, int] = (1280, 720),
    distance_m: float = 1.0,
    time_text: str = "10:00",
    mode: str = "full",
    pitch_deg: float = 45.0,
    sphere: bool = False,
    samples: int = 1,
) -> dict:
    """Render one frame, with ``samples``×``samples`` samples a pixel
    (``SandRenderer.render_still``), and write it atomically as an sRGB PNG; returns timing."""
    check_mode(mode)
    check_view(distance_m, pitch_deg)
    check_samples(samples)
    sky = sky_at(parse_time(time_text))
    check_regular_target(out)  # before the work, not after it
    ctx = standalone_context()
    material = SandMaterial(ctx)
    renderer = SandRenderer(ctx)
    try:
        material.update(preset)
        renderer.set_material(material)
        pixels, elapsed_ms = _draw(
            renderer, size, distance_m, pitch_deg, sky, mode, sphere, samples
        )
    finally:
        renderer.release()
        material.release()
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    write_atomic(out, buffer.getvalue(), make_folder=True)
    return {"ms": elapsed_ms}


def _draw(renderer, size, distance_m, pitch_deg, sky, mode, sphere, samples):
    width, height = size
    terrain = renderer.terrain
    camera = camera_at_distance(
        distance_m,
        pitch_deg,
        width / height,
        ground_height=lambda x, z: float(terrain.height(x, z)),
    )
    start = time.perf_counter()
    pixels = renderer.render_still(
        width, height, FrameRequest(camera, sky, mode, show_sphere=sphere), samples
    )
    return pixels, (time.perf_counter() - start) * 1e3
