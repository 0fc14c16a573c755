"""``sand-editor bench render``: the glints against a ground truth, their sparkle in the final
image, flicker, and frame cost.

The material is measured on the probe (the material on a flat plane under one sun, HDR values,
no terrain in the way), over the lower half of the frame: the sand nearest the camera, whose
pixels see the distance asked for. The ground truth visits every grain facet in each pixel and
draws whether it mirrors the sun (shaders/sand_surface.glsl); nothing in it is sampled, so it
has no sampling noise to converge away, and its expectation over the draws is computed too
(``ground-truth-mean``), for energies free of the draws' noise. The sparkle share is measured
on the tone-mapped image (bloom, exposure, ACES, sRGB), and on whole frames of ``sand-editor
render`` at 480×270 for the look. The frame costs (``frame_cost``) are the material's parts on
the probe and a stereo frame through the whole renderer.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import sys

import numpy as np

from sand_editor.bench._optional import pyplot
from sand_editor.bench._report import report
from sand_editor.bench.frame_cost import material_costs, stereo_cost
from sand_editor.bench.generator import machine_description
from sand_editor.bench.probe import MaterialProbe
from sand_editor.colour import luminance, srgb_to_linear
from sand_editor.gl import drawing_into, standalone_context
from sand_editor.preset import Preset
from sand_editor.render.material import SandMaterial
from sand_editor.render.post import PostChain
from sand_editor.render.request import FrameRequest
from sand_editor.resources import bundled_preset

DISTANCES = (0.1, 0.3, 1.0, 3.0, 10.0, 30.0)
TARGET_DISTANCES = (0.3, 1.0, 3.0)  # where per-pixel statistics must track the ground truth
APPROACHES = ("ours", "expected", "reference", "none")
# The expectation each approach's energy is measured by: ours by its mean over its draws.
ENERGY_FILTER = {"ours": "ours-mean", "expected": "expected", "reference": "reference",
                 "none": "none", "ground-truth": "ground-truth-mean"}  # fmt: skip
SPARKLE_RATIO = 2.0  # a sparkle: at least twice the median luminance around it
SPARKLE_WINDOW = 9  # pixels across the neighbourhood whose median that is
LOOK_SIZE = (480, 270)
LOOK_TIMES = ("12:00", "16:30")
LOOK_DISTANCES = (0.3, 1.0, 30.0)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    return srgb_to_linear(encoded.astype(np.float64) / 255.0)


def sparkle_mask(image: np.ndarray) -> np.ndarray:
    """Pixels of an sRGB uint8 image at least SPARKLE_RATIO × the median luminance of the
    SPARKLE_WINDOW² pixels around them (luminance of the displayed, decoded values)."""
    from numpy.lib.stride_tricks import sliding_window_view

    lum = luminance(srgb_decode(image[..., :3]))
    r = SPARKLE_WINDOW // 2
    padded = np.pad(lum, r, mode="reflect")
    median = np.median(sliding_window_view(padded, (SPARKLE_WINDOW, SPARKLE_WINDOW)), axis=(-2, -1))
    return (lum >= SPARKLE_RATIO * median) & (lum > 0)


def sparkle_fraction(image: np.ndarray) -> float:
    """Share of an sRGB uint8 image's pixels that are sparkles (see sparkle_mask)."""
    return float(sparkle_mask(image).mean())


def pixel_statistics(glint: np.ndarray) -> dict:
    """Per-pixel statistics of glint luminance, over its mean."""
    mean = float(glint.mean())
    if not mean > 0:
        return {"mean": mean, "cv": 0.0, "p99_over_mean": 0.0, "p999_over_mean": 0.0}
    return {
        "mean": mean,
        "cv": float(glint.std() / mean),
        "p99_over_mean": float(np.percentile(glint, 99) / mean),
        "p999_over_mean": float(np.percentile(glint, 99.9) / mean),
    }


class Bench:
    def __init__(self, quick: bool) -> None:
        self.quick = quick
        self.ctx = standalone_context()
        self.preset = Preset.load(bundled_preset("paper-default"))
        self.material = SandMaterial(self.ctx, 512 if quick else 1024)
        self.material.update(self.preset)
        width, height = (160, 120) if quick else (320, 240)
        self.probe = MaterialProbe(self.material, width, height)
        self.post = PostChain(self.ctx)
        self.post.resize(width, height)
        self._ldr = self.ctx.texture((width, height), 4)
        self._ldr_fbo = self.ctx.framebuffer([self._ldr])
        self.exposure = self._probe_exposure()
        self.repeats = 3 if quick else 7
        # Views of other sand (targets along the plane) pooled into each statistic.
        self.views = 2 if quick else 4
        self.ground_truth_samples = 4 if quick else 8  # K×K for the ground truth's albedo

    def _probe_exposure(self) -> float:
        from sand_editor.render.exposure import light_exposure
        from sand_editor.render.sky import sky_at

        sky = dataclasses.replace(
            sky_at(12.0),
            sun_direction=self.probe.sun_direction / np.linalg.norm(self.probe.sun_direction),
            sun_radiance=self.probe.sun_radiance,
            moon_radiance=np.zeros(3),
            sky_irradiance=self.probe.sky_irradiance,
        )
        return light_exposure(sky)

    def camera(self, distance: float, view: int = 0, shift=(0.0, 0.0)):
        from sand_editor.render.camera import Camera, camera_at_distance

        probe = self.probe
        target = (0.37 * view * distance, 0.23 * view * distance)
        camera = camera_at_distance(distance, 45.0, probe.width / probe.height, target_xz=target)
        if shift == (0.0, 0.0):
            return camera
        moved = probe.camera(distance, shift_px=shift)  # the same sub-pixel shift, any view
        return Camera(view=camera.view, projection=moved.projection, eye=camera.eye)

    def shade(self, distance, mode, glint_filter, view=0, shift=(0.0, 0.0)):
        """(lower half of the HDR image, ms) of the probe with a glint filter."""
        self.probe.glint_filter = glint_filter
        self.probe.ground_truth_samples = self.ground_truth_samples
        image, ms = self.probe.render(self.camera(distance, view, shift), mode, lower_half=True)
        self.probe.glint_filter = "ours"
        return image[self.probe.height // 2 :], ms

    def tone_mapped(self, hdr_lower_half: np.ndarray) -> np.ndarray:
        """The lower half through the renderer's post chain: bloom, exposure, ACES, sRGB."""
        height, width = self.probe.height, self.probe.width
        rgba = np.zeros((height, width, 4), dtype=np.float16)
        rgba[height // 2 :, :, :3] = hdr_lower_half
        rgba[..., 3] = 1.0
        self.post.scene_texture.write(np.ascontiguousarray(rgba[::-1]).tobytes())
        with drawing_into(self.ctx, self._ldr_fbo):
            self.post.finish(self._ldr_fbo, (0, 0, width, height), self.exposure)
        data = np.frombuffer(self._ldr_fbo.read(components=3, alignment=1), dtype=np.uint8)
        image = data.reshape(height, width, 3)[::-1]
        # Rows next to the empty upper half see its black in their neighbourhood: left out.
        return image[height // 2 + SPARKLE_WINDOW :]

    def sparkle(self) -> dict:
        """Per distance, per approach and the ground truth: energy against the ground truth's,
        per-pixel statistics, sparkle share of the tone-mapped image, flicker and cost."""
        results = {}
        for distance in DISTANCES:
            stats_views = self.views if distance in TARGET_DISTANCES else 1
            truth_energy = luminance(self.shade(distance, "glints", "ground-truth-mean")[0]).mean()
            per_approach = {}
            costs = self.costs_ms(distance)
            for approach in ("ground-truth", *APPROACHES):
                glints = [luminance(self.shade(distance, "glints", approach, v)[0])
                          for v in range(stats_views)]  # fmt: skip
                row = pixel_statistics(np.concatenate([g.ravel() for g in glints]))
                energy = luminance(self.shade(distance, "glints", ENERGY_FILTER[approach])[0])
                row["energy_rel_error"] = float(energy.mean() / truth_energy - 1.0)
                finals = [self.tone_mapped(self.shade(distance, "full", approach, v)[0])
                          for v in range(stats_views)]  # fmt: skip
                row["sparkle_fraction"] = float(np.mean([sparkle_fraction(f) for f in finals]))
                if approach != "ground-truth":
                    row["ms"] = costs[approach]
                per_approach[approach] = row
            self.probe.glint_filter = "ours"
            if distance in TARGET_DISTANCES:
                for approach, value in self.flicker(distance).items():
                    per_approach[approach]["flicker"] = value
            for approach in APPROACHES:
                row, truth = per_approach[approach], per_approach["ground-truth"]
                for key in ("cv", "p99_over_mean", "p999_over_mean"):
                    row[f"{key}_vs_ground_truth"] = (
                        row[key] / truth[key] - 1.0 if truth[key] > 0 else None
                    )
                row["cost_vs_reference_7x7"] = row["ms"] / per_approach["reference"]["ms"]
            results[str(distance)] = per_approach
            print(f"  sparkle at {distance} m", file=sys.stderr, flush=True)
        return results

    def costs_ms(self, distance: float) -> dict:
        """Median ms of each approach's close-range shading of the whole probe frame, the
        approaches taken in turn in every round, so that a load on the machine that comes and
        goes weighs on all of them alike."""
        camera = self.probe.camera(distance)
        times = {approach: [] for approach in APPROACHES}
        for round_ in range(self.repeats + 1):
            for approach in APPROACHES:
                self.probe.glint_filter = approach
                ms = self.probe.render(camera, "close")[1]
                if round_ > 0:  # the first round warms up
                    times[approach].append(ms)
        self.probe.glint_filter = "ours"
        return {approach: statistics.median(t) for approach, t in times.items()}

    def flicker(self, distance: float, frames: int = 4, views: int = 2) -> dict:
        """Mean frame-to-frame change of a pixel's glint luminance under sub-pixel camera
        motion, over the approach's own mean glint (views pooled): sparkles that stay on the
        surface change only where they cross pixel edges, as the facets of the ground truth
        do; an approach with no glint left has none to change (0)."""
        shifts = [(0.37 * t, 0.23 * t) for t in range(frames)]
        result = {}
        for approach in ("ground-truth", *APPROACHES):
            change, level = [], []
            for view in range(views):
                sequence = np.stack(
                    [luminance(self.shade(distance, "glints", approach, view, s)[0])
                     for s in shifts]
                )  # fmt: skip
                change.append(np.abs(np.diff(sequence, axis=0)).mean())
                level.append(sequence.mean())
            result[approach] = (
                float(np.mean(change) / np.mean(level)) if np.mean(level) > 0 else 0.0
            )
        return result

    def look(self) -> dict:
        """Sparkle share of whole frames of ``sand-editor render`` (the renderer, terrain, sky,
        bloom, tone mapping) at LOOK_SIZE, looking towards and away from the sun, for our
        glints and the reference's look (mode ``reference-look``)."""
        from sand_editor.render.camera import camera_at_distance
        from sand_editor.render.renderer import SandRenderer
        from sand_editor.render.sky import parse_time, sky_at

        renderer = SandRenderer(self.ctx)
        renderer.set_material(self.material)
        width, height = LOOK_SIZE
        results = {}
        try:
            for time_text in LOOK_TIMES:
                sky = sky_at(parse_time(time_text))
                sun = sky.sun_direction
                towards = math.degrees(math.atan2(float(sun[0]), -float(sun[2])))
                for distance in LOOK_DISTANCES:
                    for facing, heading in (("towards", towards), ("away", towards + 180.0)):
                        camera = camera_at_distance(
                            distance, 45.0, width / height, heading_deg=heading,
                            ground_height=lambda x, z: float(renderer.terrain.height(x, z)),
                        )  # fmt: skip
                        key = f"{time_text} {distance} m {facing}"
                        results[key] = {
                            mode: sparkle_fraction(
                                renderer.render_to_array(
                                    width, height, FrameRequest(camera, sky, mode)
                                )
                            )
                            for mode in ("full", "reference-look")
                        }
        finally:
            renderer.release()
        return results


def run(quick: bool = False) -> dict:
    bench = Bench(quick)
    sparkle = bench.sparkle()
    results = {
        "machine": machine_description(bench.ctx),
        "preset": bench.preset.name,
        "probe_size": [bench.probe.width, bench.probe.height],
        "texture_size": bench.material.texture_size,
        "views_pooled": bench.views,
        "sparkle": {
            d: {
                a: {k: row[k] for k in ("cv", "p99_over_mean", "sparkle_fraction")}
                for a, row in rows.items()
            }
            for d, rows in sparkle.items()
        },  # fmt: skip
        "per_distance": sparkle,
        "cost_vs_reference_7x7_close": statistics.median(
            sparkle[str(d)]["ours"]["cost_vs_reference_7x7"] for d in (0.1, 0.3, 1.0)
        ),
        "look": bench.look(),
        "frame_cost_ms_per_megapixel": material_costs(bench.probe, bench.repeats),
    }
    stereo = stereo_cost(bench.ctx, bench.material, 0.1 if bench.quick else 0.2, bench.repeats)
    results["stereo"] = stereo
    results["stereo_ms_per_megapixel"] = stereo["ms_per_megapixel"]
    return results


def _pct(value) -> str:
    return "" if value is None else f"{value * 100:+.0f} %"


def format_table(results: dict) -> str:
    lines = [
        f"Render, preset {results['preset']}, probe {results['probe_size'][0]}×"
        f"{results['probe_size'][1]} (lower half), grain textures {results['texture_size']}², "
        f"{results['machine']['gl_renderer']}",
        "",
        "| distance | approach | glint energy | CV | vs GT | p99/mean | vs GT | p99.9/mean | "
        "vs GT | sparkles in final image | flicker | ms | cost / reference 7×7 |",
        "| ---: | --- |" + " ---: |" * 11,
    ]
    for distance, rows in results["per_distance"].items():
        for approach, r in rows.items():
            flicker = f"{r['flicker']:.2f}" if "flicker" in r else ""
            ms = f"{r['ms']:.1f}" if "ms" in r else ""
            cost = f"{r['cost_vs_reference_7x7']:.2f}" if "cost_vs_reference_7x7" in r else ""
            lines.append(
                f"| {distance} m | {approach} | {r['energy_rel_error'] * 100:+.1f} % | "
                f"{r['cv']:.2f} | {_pct(r.get('cv_vs_ground_truth'))} | {r['p99_over_mean']:.1f} | "
                f"{_pct(r.get('p99_over_mean_vs_ground_truth'))} | {r['p999_over_mean']:.1f} | "
                f"{_pct(r.get('p999_over_mean_vs_ground_truth'))} | "
                f"{r['sparkle_fraction'] * 100:.3f} % | {flicker} | {ms} | {cost} |"
            )
    lines += ["", f"| {LOOK_SIZE[0]}×{LOOK_SIZE[1]} frame | ours | reference-look |",
              "| --- | ---: | ---: |"]  # fmt: skip
    for view, shares in results["look"].items():
        lines.append(
            f"| {view} | {shares['full'] * 100:.3f} % | {shares['reference-look'] * 100:.3f} % |"
        )
    lines.append("")
    lines.append(
        "Close-range cost of ours over the reference's 7×7 (median over 0.1, 0.3, 1 m): "
        f"{results['cost_vs_reference_7x7_close']:.2f}"
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
    """Per distance: glint energy error, per-pixel CV and sparkle share of each approach."""
    plt = pyplot()
    rows = results["per_distance"]
    distances = [float(d) for d in rows]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    panels = (
        ("glint energy error (%)", lambda r: r["energy_rel_error"] * 100, "linear"),
        ("per-pixel CV of glint luminance", lambda r: r["cv"], "log"),
        ("sparkles in the final image (%)", lambda r: r["sparkle_fraction"] * 100, "linear"),
    )
    styles = {"ground-truth": ("k", "o--"), "ours": ("C0", "o-"), "expected": ("C2", "s-"),
              "reference": ("C1", "^-"), "none": ("C3", "v:")}  # fmt: skip
    for ax, (label, value, scale) in zip(axes, panels, strict=True):
        for approach, (colour, style) in styles.items():
            ys = [value(rows[d][approach]) for d in rows]
            if scale == "log":
                ys = [max(y, 1e-3) for y in ys]
            ax.plot(distances, ys, style, color=colour, label=approach)
        ax.set_xscale("log")
        ax.set_yscale(scale)
        ax.set_xlabel("distance (m)")
        ax.set_title(label)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Glints of {results['preset']} against a ground truth of every facet")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    if plot_path:
        pyplot()  # before the run, so that a missing matplotlib is said at once
    return report(run(quick=quick), format_table, plot, json_path, plot_path)
