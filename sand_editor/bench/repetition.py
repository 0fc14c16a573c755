"""``sand-editor bench repetition``: how much the grain tile shows as a grid.

A frame of the material on the flat plane (bench/probe.py) is read back onto the ground: a grid
of points in the plane, TILE_SAMPLES to a tile, each projected into the frame and sampled there
(bilinearly, in luminance). The normalised autocorrelation of that ground image at a lag of one
tile, along either axis, less its mean at the neighbouring lags (0.6–0.85 and 1.15–1.4 tiles), is
the grid's strength: a tile that repeats unchanged correlates with itself a tile away far more
than anywhere near it; sand that does not repeat shows no peak there. The wind's ripples and the
fine detail are left off: they are periodic on scales of their own (a ripple a few tiles long
would show as a peak, or hide one). The same views with ``tile_variation`` off give the tile
as it repeats.
"""

from __future__ import annotations

import itertools
import sys

import numpy as np

VIEWS = ((1.0, 90.0), (3.0, 90.0), (1.0, 15.0), (3.0, 15.0))  # (distance m, pitch °)
QUICK_VIEWS = ((1.0, 90.0), (1.0, 15.0))
PRESETS = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")
SIZE = (1280, 720)  # at pitch 15 a window of 4×4 tiles at 1 m spans 80 rows of it
MODES = ("full", "close")  # what users see, and the close range alone (no blend to the far)
TILE_SAMPLES = 16  # ground samples along a tile's edge
WINDOW_TILES = 4  # the ground window's edge, in tiles
NEAR_LAGS = ((0.6, 0.85), (1.15, 1.4))  # the neighbouring lags, in tiles
TARGET = 0.1


def ground_window(camera, uv_scale: float, size, centre_xz=(0.0, 0.0)) -> np.ndarray:
    """Pixel coordinates (x right, y down, pixel centres at integers) of the ground grid's points
    around ``centre_xz``: (n, n, 2), TILE_SAMPLES to a tile of 1/uv_scale metres."""
    n = TILE_SAMPLES * WINDOW_TILES
    step = 1.0 / (uv_scale * TILE_SAMPLES)
    axis = (np.arange(n) - 0.5 * (n - 1)) * step
    z, x = np.meshgrid(axis + centre_xz[1], axis + centre_xz[0], indexing="ij")
    points = np.stack([x, np.zeros_like(x), z, np.ones_like(x)], axis=-1).astype(np.float64)
    clip = points @ np.asarray(camera.view_projection, dtype=np.float64).T
    ndc = clip[..., :2] / clip[..., 3:4]
    width, height = size
    px = (ndc[..., 0] * 0.5 + 0.5) * width - 0.5
    py = (0.5 - ndc[..., 1] * 0.5) * height - 0.5
    return np.stack([px, py], axis=-1)


def sample(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear samples of a 2D image at pixel coordinates; ValueError when a point is off it."""
    h, w = image.shape
    x, y = points[..., 0], points[..., 1]
    if x.min() < 0 or y.min() < 0 or x.max() > w - 1 or y.max() > h - 1:
        raise ValueError("the ground window does not fit in the frame")
    x0 = np.minimum(np.floor(x).astype(int), w - 2)
    y0 = np.minimum(np.floor(y).astype(int), h - 2)
    fx, fy = x - x0, y - y0
    top = image[y0, x0] * (1 - fx) + image[y0, x0 + 1] * fx
    bottom = image[y0 + 1, x0] * (1 - fx) + image[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def grid_strength(ground: np.ndarray) -> float:
    """The larger, over both axes, of the normalised autocorrelation a tile away less its mean
    over the neighbouring lags."""
    g = ground - ground.mean()
    variance = float((g * g).mean())
    if not variance > 0:
        return 0.0

    def at(lag: int, axis: int) -> float:
        a = np.moveaxis(g, axis, 0)
        return float((a[:-lag] * a[lag:]).mean() / variance)

    near_lags = [
        lag
        for low, high in NEAR_LAGS
        for lag in range(round(low * TILE_SAMPLES), round(high * TILE_SAMPLES) + 1)
    ]
    return max(
        at(TILE_SAMPLES, axis) - float(np.mean([at(lag, axis) for lag in near_lags]))
        for axis in (0, 1)
    )


def measure(probe, preset, views) -> list[dict]:
    """The grid strength of each (distance, pitch) view with the tile varied and as it repeats."""
    from sand_editor.colour import luminance

    rows = []
    for (distance, pitch), mode in itertools.product(views, MODES):
        camera = probe.camera(distance, pitch)
        points = ground_window(camera, preset.shading.uv_scale, (probe.width, probe.height))
        row = {"preset": preset.name, "distance_m": distance, "pitch_deg": pitch, "mode": mode}
        for key, varied in (("varied", True), ("repeating", False)):
            probe.tile_variation = varied
            image, _ = probe.render(camera, mode)
            row[key] = grid_strength(sample(luminance(image), points))
        probe.tile_variation = True
        rows.append(row)
    return rows


def run(quick: bool = False) -> dict:
    from sand_editor.bench.generator import machine_description
    from sand_editor.bench.probe import MaterialProbe
    from sand_editor.gl import standalone_context
    from sand_editor.preset import Preset
    from sand_editor.render.material import SandMaterial
    from sand_editor.resources import bundled_preset

    ctx = standalone_context()
    material = SandMaterial(ctx)
    probe = MaterialProbe(material, *SIZE)
    probe.ripples = False
    rows = []
    try:
        for name in PRESETS[:1] if quick else PRESETS:
            preset = Preset.load(bundled_preset(name)).replace(**{"shading.detail_strength": 0.0})
            material.update(preset)
            rows += measure(probe, preset, QUICK_VIEWS if quick else VIEWS)
    finally:
        probe.release()
        material.release()
    return {"machine": machine_description(ctx), "size": list(SIZE), "target": TARGET,
            "rows": rows}  # fmt: skip


def format_table(results: dict) -> str:
    machine = results["machine"]
    lines = [
        f"Tile repetition, {machine['gl_renderer']}, {machine['cpu_count']} CPUs",
        "",
        "| preset | distance | pitch | frame | grid, varied | grid, repeating |",
        "|---|---:|---:|---|---:|---:|",
    ]
    for r in results["rows"]:
        lines.append(
            f"| {r['preset']} | {r['distance_m']:g} m | {r['pitch_deg']:g}° | {r['mode']} "
            f"| {r['varied']:.3f} | {r['repeating']:.3f} |"
        )
    return "\n".join(lines)


def main(quick: bool = False, json_path: str | None = None) -> int:
    from sand_editor.bench._report import report

    results = run(quick)
    report(results, format_table, lambda *_: None, json_path)
    worst = max(r["varied"] for r in results["rows"])
    print(f"largest grid strength, varied: {worst:.3f} (target ≤ {TARGET})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
