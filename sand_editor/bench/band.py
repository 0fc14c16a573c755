"""``sand-editor bench band``: where the close shading hands over to the far one, does the frame
brighten or darken in a band?

Each view is rendered three times by the renderer at the light's exposure: ``full`` (the
blend), ``close`` and ``far``. Per row of the ground (HDR luminance, below the horizon), the
full frame's mean should lie between the close and far frames' means: the blend only chooses
which work is done, so anything outside is light that neither range holds, a band across the
frame. A row's excess is how far the full mean lies outside [min, max] of the two, as a share
of the nearer bound; a view's is its worst row's. Target: ≤ TOLERANCE in every row.
"""

from __future__ import annotations

import sys

import numpy as np

from sand_editor.render.request import FrameRequest

DISTANCES = (0.05, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0)
QUICK_DISTANCES = (0.05, 0.3, 1.0)
TIMES = ("16:30", "12:00")
PITCH_DEG = 15.0
SIZE = (160, 90)
GROUND_FROM = 0.4  # rows below this share of the frame's height: the ground, at pitch 15°
TOLERANCE = 0.05
PRESETS = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")


def row_means(renderer, camera, sky, mode: str, size=SIZE) -> np.ndarray:
    """Mean HDR luminance of each ground row of a frame at the light's exposure."""
    from sand_editor.colour import luminance
    from sand_editor.render.exposure import light_exposure

    width, height = size
    renderer.render_to_array(
        width, height, FrameRequest(camera, sky, mode, exposure=light_exposure(sky))
    )
    hdr = np.frombuffer(renderer.post.scene_texture.read(), dtype=np.float16)
    hdr = hdr.reshape(height, width, -1)[::-1, :, :3].astype(np.float64)
    assert np.isfinite(hdr).all(), f"{mode} frame is not finite"
    return luminance(hdr[int(GROUND_FROM * height) :]).mean(axis=1)


def band_excess(full: np.ndarray, close: np.ndarray, far: np.ndarray) -> float:
    """The worst row's share by which the full frame's mean lies outside its close and far
    frames' means (0 where it lies between them)."""
    low, high = np.minimum(close, far), np.maximum(close, far)
    over = np.where(full > high, full / np.maximum(high, 1e-12) - 1.0, 0.0)
    under = np.where(full < low, 1.0 - full / np.maximum(low, 1e-12), 0.0)
    return float(np.max(np.maximum(over, under)))


def measure(renderer, preset, distances, times=TIMES) -> list[dict]:
    """The band excess of each (distance, time) view of the preset (set on the renderer)."""
    from sand_editor.render.camera import camera_at_distance
    from sand_editor.render.sky import parse_time, sky_at

    width, height = SIZE
    terrain = renderer.terrain
    rows = []
    for time_text in times:
        sky = sky_at(parse_time(time_text))
        for distance in distances:
            camera = camera_at_distance(
                distance, PITCH_DEG, width / height,
                ground_height=lambda x, z: float(terrain.height(x, z)),
            )  # fmt: skip
            modes = ("full", "close", "far")
            means = {mode: row_means(renderer, camera, sky, mode) for mode in modes}
            rows.append({
                "preset": preset.name, "time": time_text, "distance_m": distance,
                "excess": band_excess(means["full"], means["close"], means["far"]),
                "close_over_far": float(means["close"].mean() / means["far"].mean()),
            })  # fmt: skip
    return rows


def run(quick: bool = False) -> dict:
    from sand_editor.bench.generator import machine_description
    from sand_editor.gl import standalone_context
    from sand_editor.preset import Preset
    from sand_editor.render.material import SandMaterial
    from sand_editor.render.renderer import SandRenderer
    from sand_editor.resources import bundled_preset

    ctx = standalone_context()
    material = SandMaterial(ctx, 256)
    renderer = SandRenderer(ctx)
    rows = []
    try:
        for name in PRESETS[:1] if quick else PRESETS:
            preset = Preset.load(bundled_preset(name))
            material.update(preset)
            renderer.set_material(material)
            rows += measure(renderer, preset, QUICK_DISTANCES if quick else DISTANCES)
    finally:
        renderer.release()
        material.release()
    return {"machine": machine_description(ctx), "size": list(SIZE), "pitch_deg": PITCH_DEG,
            "tolerance": TOLERANCE, "rows": rows}  # fmt: skip


def format_table(results: dict) -> str:
    machine = results["machine"]
    lines = [
        f"Near–far band, {machine['gl_renderer']}, {machine['cpu_count']} CPUs",
        "",
        "| preset | time | distance | worst row outside close–far | close / far |",
        "|---|---|---:|---:|---:|",
    ]
    for r in results["rows"]:
        lines.append(
            f"| {r['preset']} | {r['time']} | {r['distance_m']:g} m "
            f"| {r['excess']:.1%} | {r['close_over_far']:.3f} |"
        )
    return "\n".join(lines)


def main(quick: bool = False, json_path: str | None = None) -> int:
    from sand_editor.bench._report import report

    results = run(quick)
    report(results, format_table, lambda *_: None, json_path)
    worst = max(r["excess"] for r in results["rows"])
    print(f"worst row outside close–far: {worst:.1%} (target ≤ {TOLERANCE:.0%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
