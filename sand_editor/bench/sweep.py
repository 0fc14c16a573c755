"""The appearance sweep: shipped and random valid presets at every distance and two suns.

For each preset and view it measures what a person would see go wrong: NaN or inf in the HDR
frame, the share of the ground clipped white in the final frame (bloom, exposure, ACES, sRGB,
through the whole renderer), and the ratio of the close range's mean radiance to the far
range's on the probe's plane (the sparkle taken at its expectation, so that the ratio measures
the model rather than the draw). The suite runs a small version of it; ``sand-editor bench
appearance`` runs it whole.
"""

from __future__ import annotations

import numpy as np

from sand_editor.bench.probe import MaterialProbe
from sand_editor.preset import FIELDS, Color, Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.sky import parse_time, sky_at
from sand_editor.resources import bundled_preset

SHIPPED = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")
DISTANCES = (0.3, 1.0, 3.0, 10.0, 30.0)
# Noon, and a low sun ahead of the camera (glints towards it); as scene times for the frames.
SUNS = {"noon": ((0.2, 0.95, -0.25), "12:00"), "low": ((0.0, 0.2, -0.98), "17:45")}
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
CLIPPED = 250  # an 8-bit channel value at or above which a pixel reads as white
# Fields whose extremes make no sand to look at: a tile of 1 μm or 100 m, a blend that never
# shows one range. Drawn within a range people use instead.
_USED_RANGE = {
    "shading.uv_scale": (1.0, 100.0),
    "shading.sigmoid_a": (0.5, 20.0),
    "shading.sigmoid_b": (-5.0, 50.0),
}


def _colour(rng: np.random.Generator) -> Color:
    return Color.from_hex(f"#{int(rng.integers(0, 1 << 24)):06x}")


def random_preset(rng: np.random.Generator, name: str = "random") -> Preset:
    """A valid preset drawn from the field table: each number at its minimum, its maximum or
    in between, with equal chances; colours and weights at random."""
    changes = {}
    for spec in FIELDS:
        if spec.section == "" or spec.kind == "text":
            continue
        low, high = _USED_RANGE.get(spec.path, (spec.minimum, spec.maximum))
        if spec.kind == "color":
            changes[spec.path] = _colour(rng)
        elif spec.kind == "colors":
            changes[spec.path] = tuple(_colour(rng) for _ in range(spec.count))
        elif spec.kind == "weights":
            weights = rng.integers(0, 101, size=spec.count).astype(float)
            weights[rng.integers(spec.count)] = max(weights.max(), 1.0)
            changes[spec.path] = tuple(weights)
        else:
            pick = rng.integers(3)
            value = low if pick == 0 else high if pick == 1 else rng.uniform(low, high)
            if spec.path == "generation.period":
                value = min(value, 128)  # a cell of at least two texels at the sweep's size
            changes[spec.path] = int(round(value)) if spec.kind == "int" else float(value)
    return Preset(name=name).replace(**changes)


def sweep_presets(random_count: int, seed: int = 2026) -> list[Preset]:
    rng = np.random.default_rng(seed)
    shipped = [Preset.load(bundled_preset(name)) for name in SHIPPED]
    return shipped + [random_preset(rng, f"random-{i}") for i in range(random_count)]


class Sweep:
    """A material, its probe and a renderer on one context, reused for every preset."""

    def __init__(self, ctx, texture_size: int = 256, probe_size=(96, 54), frame_size=(160, 90)):
        self.material = SandMaterial(ctx, texture_size)
        self.probe = MaterialProbe(self.material, *probe_size)
        self.renderer = SandRenderer(ctx)
        self.frame_size = frame_size

    def measure(self, preset: Preset, distances=DISTANCES, suns=tuple(SUNS)) -> list[dict]:
        self.material.update(preset)
        self.renderer.set_material(self.material)
        rows = []
        for sun in suns:
            direction, time_text = SUNS[sun]
            self.probe.sun_direction = np.array(direction, dtype=float)
            for distance in distances:
                rows.append({"preset": preset.name, "sun": sun, "distance_m": distance,
                             **self._view(distance, time_text)})  # fmt: skip
        return rows

    def _view(self, distance: float, time_text: str) -> dict:
        probe = self.probe
        camera = probe.camera(distance, 35.0)
        means, finite = {}, True
        probe.glint_filter = "ours-mean"
        for mode in ("close", "far"):
            image, _ = probe.render(camera, mode, lower_half=True)
            finite &= bool(np.isfinite(image).all())
            means[mode] = float((image[probe.height // 2 :] @ LUMINANCE).mean())
        probe.glint_filter = "ours"
        image, _ = probe.render(camera, "full", lower_half=True)
        finite &= bool(np.isfinite(image).all())
        frame, frame_finite = self.frame(distance, time_text)
        ground = frame[frame.shape[0] // 2 :]
        return {
            "finite": finite and frame_finite,
            "close": means["close"],
            "far": means["far"],
            "close_over_far": means["close"] / means["far"] if means["far"] > 0 else 1.0,
            "clipped": float((ground.min(axis=-1) >= CLIPPED).mean()),
        }

    def frame(self, distance: float, time_text: str) -> tuple[np.ndarray, bool]:
        width, height = self.frame_size
        terrain = self.renderer.terrain
        camera = camera_at_distance(
            distance, 35.0, width / height, ground_height=lambda x, z: float(terrain.height(x, z))
        )
        frame = self.renderer.render_to_array(width, height, camera, sky_at(parse_time(time_text)))
        hdr = np.frombuffer(self.renderer.post.scene_texture.read(), dtype=np.float16)
        return frame, bool(np.isfinite(hdr).all())

    def release(self) -> None:
        self.renderer.release()
        self.probe.release()
        self.material.release()


def run(quick: bool = False) -> dict:
    from sand_editor.bench.generator import machine_description
    from sand_editor.gl import standalone_context

    ctx = standalone_context()
    sweep = Sweep(ctx)
    try:
        rows = [row for p in sweep_presets(4 if quick else 16) for row in sweep.measure(p)]
    finally:
        sweep.release()
    from sand_editor.bench.mitsuba_reference import compare

    shipped = [Preset.load(bundled_preset(name)) for name in SHIPPED]
    presets = shipped[:1] if quick else shipped
    distances = (3.0,) if quick else (1.0, 3.0, 10.0, 30.0)
    reference = compare(presets, distances, spp=16 if quick else 64)
    return {"machine": machine_description(ctx), "rows": rows, "mitsuba": reference}


def format_table(results: dict) -> str:
    lines = [
        "Appearance sweep, {gl_renderer}, {cpu_count} CPUs".format(**results["machine"]),
        "",
        "| preset | worst close/far (at) | clipped white, most | NaN or inf |",
        "| --- | ---: | ---: | --- |",
    ]
    names = dict.fromkeys(row["preset"] for row in results["rows"])
    for name in names:
        rows = [row for row in results["rows"] if row["preset"] == name]
        worst = max(rows, key=lambda row: abs(row["close_over_far"] - 1.0))
        at = f"{worst['distance_m']:g} m, {worst['sun']} sun"
        clipped = max(row["clipped"] for row in rows)
        finite = "none" if all(row["finite"] for row in rows) else "**yes**"
        lines.append(
            f"| {name} | {worst['close_over_far']:.3f} ({at}) | {clipped * 100:.2f} % | {finite} |"
        )
    if results.get("mitsuba"):
        from sand_editor.bench.mitsuba_reference import format_rows

        lines += [
            "",
            "Against Mitsuba 3 (scalar_rgb), mean HDR luminance, ours over Mitsuba's:",
            "",
        ]
        lines.append(format_rows(results["mitsuba"]))
    return "\n".join(lines)


def contact_sheet(path: str, size=(320, 180), distances=(0.3, 3.0, 30.0), time_text="16:30"):
    """The shipped sands (rows) at each distance (columns), as the renderer shows them."""
    from PIL import Image

    from sand_editor.gl import standalone_context

    ctx = standalone_context()
    sweep = Sweep(ctx, texture_size=1024, frame_size=size)
    sheet = Image.new("RGB", (size[0] * len(distances), size[1] * len(SHIPPED)))
    try:
        for row, name in enumerate(SHIPPED):
            sweep.material.update(Preset.load(bundled_preset(name)))
            sweep.renderer.set_material(sweep.material)
            for column, distance in enumerate(distances):
                frame, _ = sweep.frame(distance, time_text)
                sheet.paste(Image.fromarray(frame), (column * size[0], row * size[1]))
    finally:
        sweep.release()
    sheet.save(path)


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    from sand_editor.bench._report import report
    from sand_editor.bench.mitsuba_reference import load_mitsuba

    load_mitsuba()  # before the run, so that a missing Mitsuba is said at once
    return report(run(quick), format_table, lambda _r, p: contact_sheet(p), json_path, plot_path)
