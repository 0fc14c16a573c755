"""``sand-editor bench render``: the material's speed against error, flicker and frame cost.

Everything is measured on the material probe (the material on a flat plane, one sun, HDR
values, no terrain or post-processing in the way), except the stereo frame, which is the whole
renderer. The ground truth is the close-range shading evaluated at the finest texture level with
K×K jittered samples per pixel.
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from sand_editor.bench._report import report
from sand_editor.bench.generator import machine_description
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.render.material import CLOSE_CUTOFF, SandMaterial
from sand_editor.render.probe import MaterialProbe
from sand_editor.resources import bundled_preset

DISTANCES = (0.1, 0.3, 1.0, 3.0, 10.0, 30.0)
SAMPLE_COUNTS = (1, 3, 5, 7, 9)
APPROACHES = ("ours", "reference")
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
STEREO_EYE = (1832, 1920)


def luminance(image: np.ndarray) -> np.ndarray:
    return image @ LUMINANCE


class Bench:
    def __init__(self, quick: bool) -> None:
        self.quick = quick
        self.ctx = standalone_context()
        self.preset = Preset.load(bundled_preset("paper-default"))
        self.material = SandMaterial(self.ctx, 512 if quick else 1024)
        self.material.update(self.preset)
        width, height = (160, 120) if quick else (320, 240)
        self.probe = MaterialProbe(self.material, width, height)
        self.gt_samples = 8 if quick else 16
        self.repeats = 2 if quick else 3

    def shade(self, distance, mode="close", glint_filter="ours", sample_count=None, shift=(0, 0)):
        """(image, median ms) of the probe at a distance with a filter and sample count."""
        preset = self.preset
        if sample_count is not None:
            preset = preset.replace(**{"shading.sample_count": sample_count})
        self.material.update(preset)
        self.material.glint_filter = glint_filter
        self.material.ground_truth_samples = self.gt_samples
        camera = self.probe.camera(distance, shift_px=shift)
        times, image = [], None
        for _ in range(1 if glint_filter == "ground-truth" else self.repeats):
            image, ms = self.probe.render(camera, mode)
            times.append(ms)
        self.material.update(self.preset)
        return image, statistics.median(times)

    def curves(self) -> tuple[dict, dict, dict]:
        curves, default_error, costs = {}, {}, []
        default_n = self.preset.shading.sample_count
        for distance in DISTANCES:
            truth, _ = self.shade(distance, "close", "ground-truth")
            truth_glint, _ = self.shade(distance, "glints", "ground-truth")
            truth_lum, truth_energy = luminance(truth), luminance(truth_glint).mean()
            per_distance = {}
            for approach in APPROACHES:
                for n in SAMPLE_COUNTS:
                    image, ms = self.shade(distance, "close", approach, n)
                    glint, _ = self.shade(distance, "glints", approach, n)
                    energy = luminance(glint).mean()
                    per_distance[f"{approach}-{n}"] = {
                        "approach": approach,
                        "sample_count": n,
                        "mae": float(np.abs(luminance(image) - truth_lum).mean()),
                        "glint_energy_rel_error": float(energy / truth_energy - 1.0),
                        "ms": ms,
                        "default": n == default_n,
                    }
            image, ms = self.shade(distance, "close", "none")
            glint, _ = self.shade(distance, "glints", "none")
            per_distance["none"] = {
                "approach": "none",
                "sample_count": 1,
                "mae": float(np.abs(luminance(image) - truth_lum).mean()),
                "glint_energy_rel_error": float(luminance(glint).mean() / truth_energy - 1.0),
                "ms": ms,
                "default": False,
            }
            curves[str(distance)] = per_distance
            default_error[str(distance)] = per_distance[f"ours-{default_n}"][
                "glint_energy_rel_error"
            ]
            costs.append(
                per_distance[f"ours-{default_n}"]["ms"] / per_distance["reference-7"]["ms"]
            )
            print(f"  curves at {distance} m", file=sys.stderr, flush=True)
        return curves, default_error, {"median": statistics.median(costs), "per_distance": costs}

    def flicker(self, distance: float = 1.0, frames: int = 8) -> dict:
        """Mean frame-to-frame luminance change of glint pixels under sub-pixel camera motion, as
        a fraction of their mean true glint luminance; the ground truth's own value is the floor
        (motion itself changes what a pixel sees)."""
        shifts = [(0.37 * t, 0.23 * t) for t in range(frames)]
        sequences = {}
        for name, glint_filter in (("truth", "ground-truth"), ("none", "none"),
                                   ("reference", "reference"), ("ours", "ours")):  # fmt: skip
            sequences[name] = np.stack(
                [
                    luminance(self.shade(distance, "glints", glint_filter, shift=s)[0])
                    for s in shifts
                ]
            )
        truth = sequences["truth"]
        glinting = truth.max(axis=0) > np.percentile(truth.max(axis=0), 95)
        level = float(truth[:, glinting].mean())

        def change(seq):
            return float(np.abs(np.diff(seq, axis=0))[:, glinting].mean()) / level

        result = {name: change(seq) for name, seq in sequences.items()}
        result["ground_truth"] = result.pop("truth")
        result["distance_m"] = distance
        return result

    def frame_costs(self) -> dict:
        """Per-megapixel costs of the parts of a frame, and what skipping negligible close-range
        work saves, on a view whose far half is past the blend."""
        distance = 4.0
        pitch_view = {}
        for name, mode, cutoff in (
            ("close", "close", 2.0),
            ("far", "far", 2.0),
            ("full_without_skip", "full", 2.0),
            ("full", "full", CLOSE_CUTOFF),
        ):
            self.material.close_cutoff = cutoff
            self.material.glint_filter = "ours"
            camera = self.probe.camera(distance, pitch_deg=12.0)
            times = [self.probe.render(camera, mode)[1] for _ in range(self.repeats)]
            pitch_view[name] = statistics.median(times)
        self.material.close_cutoff = CLOSE_CUTOFF
        megapixels = self.probe.width * self.probe.height / 1e6
        per_mp = {k: v / megapixels for k, v in pitch_view.items()}
        per_mp["skip_saving"] = 1.0 - pitch_view["full"] / pitch_view["full_without_skip"]
        return per_mp

    def stereo(self) -> dict:
        """A stereo frame through the whole renderer at a fraction of 1832×1920 per eye."""
        from sand_editor.render.camera import camera_at_distance
        from sand_editor.render.renderer import SandRenderer
        from sand_editor.render.sky import sky_at

        scale = 0.1 if self.quick else 0.2
        width, height = (max(16, int(s * scale)) for s in STEREO_EYE)
        renderer = SandRenderer(self.ctx)
        renderer.set_material(self.material)
        sky = sky_at(10.0)
        target = self.ctx.framebuffer([self.ctx.texture((2 * width, height), 4)])
        left = camera_at_distance(2.0, 30.0, width / height, target_xz=(-0.032, 0.0))
        right = camera_at_distance(2.0, 30.0, width / height, target_xz=(0.032, 0.0))

        def frame():
            renderer.render(target, left, sky, viewport=(0, 0, width, height))
            renderer.render(target, right, sky, viewport=(width, 0, width, height))
            self.ctx.finish()

        frame()
        times = []
        for _ in range(self.repeats):
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


def run(quick: bool = False) -> dict:
    bench = Bench(quick)
    curves, default_error, cost = bench.curves()
    results = {
        "machine": machine_description(bench.ctx),
        "preset": bench.preset.name,
        "probe_size": [bench.probe.width, bench.probe.height],
        "texture_size": bench.material.texture_size,
        "ground_truth_samples": bench.gt_samples**2,
        "curves": curves,
        "default_relative_error": default_error,
        "cost_vs_reference_7x7": cost["median"],
        "cost_vs_reference_7x7_per_distance": dict(
            zip(map(str, DISTANCES), cost["per_distance"], strict=True)
        ),
        "flicker": bench.flicker(),
        "frame_cost_ms_per_megapixel": bench.frame_costs(),
    }
    stereo = bench.stereo()
    results["stereo"] = stereo
    results["stereo_ms_per_megapixel"] = stereo["ms_per_megapixel"]
    return results


def format_table(results: dict) -> str:
    n = next(
        v["sample_count"] for v in next(iter(results["curves"].values())).values() if v["default"]
    )
    lines = [
        f"Render, preset {results['preset']}, probe {results['probe_size'][0]}×"
        f"{results['probe_size'][1]}, ground truth {results['ground_truth_samples']} samples per "
        f"pixel, {results['machine']['gl_renderer']}",
        "",
        "| distance | approach | N | luminance MAE | glint energy error | ms |",
        "| ---: | --- | ---: | ---: | ---: | ---: |",
    ]
    for distance, rows in results["curves"].items():
        for r in rows.values():
            mark = " (default)" if r["default"] and r["approach"] == "ours" else ""
            lines.append(
                f"| {distance} m | {r['approach']}{mark} | {r['sample_count']} | {r['mae']:.4f} | "
                f"{r['glint_energy_rel_error'] * 100:+.1f} % | {r['ms']:.1f} |"
            )
    lines.append("")
    errors = ", ".join(
        f"{d} m: {e * 100:+.1f} %" for d, e in results["default_relative_error"].items()
    )
    lines.append(f"Glint energy error of ours at the default (N = {n}): {errors}")
    cost = results["cost_vs_reference_7x7"]
    lines.append(f"Cost of ours at the default over the reference's 7×7: {cost:.2f}")
    f = results["flicker"]
    lines.append(
        f"Flicker at {f['distance_m']} m (frame-to-frame change of glint pixels over their true "
        f"luminance): none {f['none']:.2f}, reference 7×7 {f['reference']:.2f}, "
        f"ours {f['ours']:.2f}, ground truth {f['ground_truth']:.2f}"
    )
    c = results["frame_cost_ms_per_megapixel"]
    lines.append(
        "Material cost, ms per megapixel: "
        f"close {c['close']:.0f}, far {c['far']:.0f}, full {c['full']:.0f} "
        f"(without skipping negligible close work {c['full_without_skip']:.0f}: "
        f"skipping saves {c['skip_saving'] * 100:.0f} %)"
    )
    s = results["stereo"]
    lines.append(
        f"Stereo frame, whole renderer, {s['eye_size'][0]}×{s['eye_size'][1]} per eye: "
        f"{s['ms']:.0f} ms = {s['ms_per_megapixel']:.0f} ms per megapixel "
        f"(at 1832×1920 per eye: about {s['estimated_full_size_ms']:.0f} ms on this machine)"
    )
    return "\n".join(lines)


def plot(results: dict, path: str) -> None:
    """Per distance: glint energy error (top) and luminance MAE (bottom) against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    distances = list(results["curves"])
    fig, axes = plt.subplots(2, len(distances), figsize=(3.0 * len(distances), 5.6), sharey="row")
    axes = np.atleast_2d(axes)
    metrics = (
        ("glint energy error (%)", lambda r: abs(r["glint_energy_rel_error"]) * 100),
        ("luminance MAE", lambda r: r["mae"]),
    )
    for column, distance in enumerate(distances):
        rows = results["curves"][distance]
        for row, (label, value) in enumerate(metrics):
            ax = axes[row, column]
            for approach, colour in (("ours", "C0"), ("reference", "C1")):
                points = sorted(
                    (r["ms"], value(r), r["default"])
                    for r in rows.values()
                    if r["approach"] == approach
                )
                ax.plot([p[0] for p in points], [p[1] for p in points], "o-", color=colour,
                        label=approach)  # fmt: skip
                for ms, v, is_default in points:
                    if is_default:
                        ax.plot(ms, v, "*", color=colour, markersize=14)
            ax.plot(rows["none"]["ms"], value(rows["none"]), "s", color="C3", label="none")
            ax.set_xscale("log")
            ax.minorticks_off()
            if row == 0:
                ax.set_title(f"{distance} m")
            else:
                ax.set_xlabel("ms (probe)")
            if column == 0:
                ax.set_ylabel(label)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Close-range shading against a 256-sample ground truth (★ = preset default)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    return report(run(quick=quick), format_table, plot, json_path, plot_path)
