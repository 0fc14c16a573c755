"""``sand-editor bench gpu``: what one graphics card (or CPU rasterizer) makes of the sand, in a
single headless command that needs no display, Qt or OpenXR, so that it can be carried to a
machine with no network: ``tools/gpu-bench-venv`` builds the five packages it needs.

Three parts, all on the OpenGL that EGL gives:

- the viewer's stereo frame through its real frame loop (``vr.loop.FrameLoop`` with
  ``vr.headless.HeadlessBackend``), at 2064×2208 and 1832×1920 per eye (Quest 3's and Quest 2's
  recommended sizes): both eyes until drawn, the loop's own work, and their sum, median and 90th
  percentile over the frames after a warm-up, run for a time box (a few frames on a CPU
  rasterizer, up to 200 on a GPU);
- the GLSL grain generator at 1024² and 2048², its textures left on the GPU and with the
  read-back to numpy (``bench.generator``);
- the render bench's frame costs: each glint approach's close-range shading of the probe per
  distance, and the material's parts per megapixel (``bench.render``, ``bench.frame_cost``).

    sand-editor bench gpu [--quick] [--sizes N ...] [--json FILE]
    python -m sand_editor.bench.gpu [--eye-scale S] [--frames N] ...
        the same, with the eye sizes × S, and N timed frames after one to warm up
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from dataclasses import asdict, dataclass

import numpy as np

from sand_editor.bench._report import report
from sand_editor.bench.frame_cost import material_costs
from sand_editor.bench.generator import _ours, machine_description
from sand_editor.bench.render import DISTANCES, Bench
from sand_editor.generator import check_size
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset
from sand_editor.untrusted import integer, number
from sand_editor.vr import resident_mb
from sand_editor.vr.desktop import FOV_Y_DEG
from sand_editor.vr.glwindow import HeadlessContexts
from sand_editor.vr.headless import HeadlessBackend
from sand_editor.vr.link import NullLink
from sand_editor.vr.loop import FrameLoop, ViewerOptions

EYE_SIZES = ((2064, 2208), (1832, 1920))
GENERATOR_SIZES = (1024, 2048)
QUICK_EYE_SCALE = 0.5
PRESET = "paper-default"
MAX_WARM_UP_FRAMES = 20
APPROACH_TITLES = {"ours": "ours", "expected": "expected", "reference": "reference 7×7",
                   "none": "none"}  # fmt: skip
EDGE_MODULES = ("PySide6", "xr")  # what the command must not import


@dataclass(frozen=True)
class FrameBudget:
    """How many frames: a warm-up of at least ``warm_up`` frames lasting ``warm_up_s``, then
    timed frames until ``time_box_s`` has passed, at least ``min_frames``, at most
    ``max_frames``."""

    warm_up: int
    warm_up_s: float
    min_frames: int
    max_frames: int
    time_box_s: float


FULL = FrameBudget(warm_up=2, warm_up_s=2.0, min_frames=3, max_frames=200, time_box_s=30.0)
QUICK = FrameBudget(warm_up=1, warm_up_s=0.5, min_frames=3, max_frames=50, time_box_s=5.0)


class _FrameCounter:
    """The headless backend's ``stop_after``: ends the warm-up, then the timed frames."""

    def __init__(self, budget: FrameBudget) -> None:
        self.budget = budget
        self.warm_up: int | None = None  # frames before the timed ones, once they begin
        self._since = time.perf_counter()

    def __call__(self, ended: int) -> bool:
        budget, now = self.budget, time.perf_counter()
        if self.warm_up is None:
            if ended >= budget.warm_up and (
                now - self._since >= budget.warm_up_s or ended >= MAX_WARM_UP_FRAMES
            ):
                self.warm_up, self._since = ended, now
            return False
        timed = ended - self.warm_up
        return timed >= budget.max_frames or (
            timed >= budget.min_frames and now - self._since >= budget.time_box_s
        )


class _BenchLoop(FrameLoop):
    """The viewer's frame loop, whose resource counts leave out the GL objects where PyOpenGL,
    which counts them, is not installed (it is not in the benchmark's minimal environment)."""

    def _resources(self) -> dict:
        try:
            return super()._resources()
        except ImportError:
            return {"frame": self.stats.frames_submitted, "resident_mb": round(resident_mb(), 1)}


def _summary(values) -> dict:
    values = np.asarray(values, dtype=np.float64)
    return {
        "median": round(float(np.median(values)), 3),
        "p90": round(float(np.percentile(values, 90)), 3),
    }


def stereo_frames(size: tuple[int, int], budget: FrameBudget, preset: Preset) -> dict:
    """Stereo frames of the viewer at ``size`` per eye through the headless backend."""
    windows = HeadlessContexts()
    backend = loop = None
    try:
        backend = HeadlessBackend(windows, size)
        loop = _BenchLoop(backend, windows, NullLink(), ViewerOptions(preset, PRESET))
        start = time.perf_counter()
        loop.start()
        start_s = time.perf_counter() - start
        counter = backend.stop_after = _FrameCounter(budget)
        loop.run()
        images = [backend.eye_image(index) for index in range(2)]
        texture_size = loop.options.texture_size
    finally:
        if loop is not None:
            loop.close()
        if backend is not None:
            backend.close()  # and the contexts
        else:
            windows.close()
    stats, skip = loop.stats, counter.warm_up
    eyes = np.asarray(stats.eye_ms[2 * skip :]).reshape(-1, 2).sum(axis=1)
    own = np.asarray(stats.overhead_ms[skip:])
    total = eyes + own
    return {
        "eye_size": list(size),
        "grain_texture_size": texture_size,
        "start_s": round(start_s, 3),
        "frames_warm_up": skip,
        "frames_timed": int(total.size),
        "eyes_ms": _summary(eyes),
        "own_work_ms": _summary(own),
        "total_ms": _summary(total),
        "frames_per_s": round(1e3 / float(np.median(total)), 2),
        "eye_mean_level": [round(float(image.mean()), 2) for image in images],
        "eyes_differ": bool(np.any(images[0] != images[1])),
    }


def generator_times(ctx, preset: Preset, sizes, repeats: int) -> dict:
    """The GLSL generator per size: on the GPU, and with the read-back (and its errors)."""
    rows = {}
    for size in sizes:
        measured, _ = _ours(ctx, preset, size, repeats, with_reference=False)
        rows[str(size)] = measured["ours-gl"]
        print(f"  generator at {size}²", file=sys.stderr, flush=True)
    return rows


def render_costs(quick: bool) -> dict:
    """The render bench's cost rows: close-range shading per distance and approach, and the
    material's parts per megapixel."""
    bench = Bench(quick)
    per_distance = {str(distance): bench.costs_ms(distance) for distance in DISTANCES}
    return {
        "probe_size": [bench.probe.width, bench.probe.height],
        "texture_size": bench.material.texture_size,
        "repeats": bench.repeats,
        "per_distance_ms": per_distance,
        "material_ms_per_megapixel": material_costs(bench.probe, bench.repeats),
    }


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def eye_sizes(scale: float) -> list[tuple[int, int]]:
    return [(max(16, round(w * scale)), max(16, round(h * scale))) for w, h in EYE_SIZES]


def fixed_frames(frames: int) -> FrameBudget:
    """Exactly ``frames`` timed frames after one to warm up."""
    return FrameBudget(warm_up=1, warm_up_s=0.0, min_frames=frames, max_frames=frames,
                       time_box_s=0.0)  # fmt: skip


def run(
    quick: bool = False, sizes=None, eye_scale: float | None = None, frames: int | None = None
) -> dict:
    started = time.perf_counter()
    ctx = standalone_context()
    preset = Preset.load(bundled_preset(PRESET))
    budget = fixed_frames(frames) if frames else QUICK if quick else FULL
    scale = eye_scale if eye_scale is not None else QUICK_EYE_SCALE if quick else 1.0
    sizes = [check_size(s) for s in sizes] if sizes else GENERATOR_SIZES
    results: dict = {
        "machine": {**machine_description(ctx), "cpu_model": cpu_model()},
        "quick": quick,
        "preset": preset.name,
        "frame_budget": asdict(budget),
        "fov_y_deg": FOV_Y_DEG,
        "stereo": {},
    }
    for size in eye_sizes(scale):
        results["stereo"][f"{size[0]}x{size[1]}"] = stereo_frames(size, budget, preset)
        print(f"  stereo frames at {size[0]}×{size[1]} per eye", file=sys.stderr, flush=True)
    ctx = standalone_context()  # current again after the frame loop's contexts
    results["generator"] = generator_times(ctx, preset, sizes, 3 if quick else 7)
    results["render_costs"] = render_costs(quick)
    print("  render costs", file=sys.stderr, flush=True)
    results["modules_qt_or_xr"] = sorted(
        name for name in sys.modules if name.split(".")[0] in EDGE_MODULES
    )
    results["wall_s"] = round(time.perf_counter() - started, 1)
    return results


def format_table(results: dict) -> str:
    m = results["machine"]
    lines = [
        f"GPU bench{' (quick)' if results['quick'] else ''}, preset {results['preset']}: "
        f"{m['gl_renderer']} ({m['gl_version']}), CPU {m['cpu_model']}, {m['cpu_count']} cores",
        "",
        f"Stereo frame through the viewer's frame loop (headless, {results['fov_y_deg']:g}° "
        "vertical field of view), per frame after the warm-up:",
        "",
        "| per eye | frames | both eyes ms | p90 | own work ms | p90 | total ms | p90 | frames/s |",
        "| ---: | ---: |" + " ---: |" * 7,
    ]
    for row in results["stereo"].values():
        eyes, own, total = row["eyes_ms"], row["own_work_ms"], row["total_ms"]
        lines.append(
            f"| {row['eye_size'][0]}×{row['eye_size'][1]} | {row['frames_timed']} | "
            f"{eyes['median']:.1f} | {eyes['p90']:.1f} | {own['median']:.2f} | {own['p90']:.2f} | "
            f"{total['median']:.1f} | {total['p90']:.1f} | {row['frames_per_s']:.1f} |"
        )
    lines += [
        "",
        "| generator | on the GPU ms | + read-back ms | megapixels/s on the GPU |",
        "| ---: | ---: | ---: | ---: |",
    ]
    for size, row in results["generator"].items():
        megapixels = int(size) ** 2 / 1e6
        lines.append(
            f"| {size}² | {row['median_s'] * 1e3:.1f} | {row['median_with_readback_s'] * 1e3:.1f} "
            f"| {megapixels / row['median_s']:.0f} |"
        )
    costs = results["render_costs"]
    width, height = costs["probe_size"]
    lines += [
        "",
        f"Close-range glint shading of the {width}×{height} probe, grain textures "
        f"{costs['texture_size']}², median ms:",
        "",
        "| distance | " + " | ".join(APPROACH_TITLES.values()) + " |",
        "| ---: |" + " ---: |" * len(APPROACH_TITLES),
    ]
    for distance, row in costs["per_distance_ms"].items():
        cells = " | ".join(f"{row[key]:.1f}" for key in APPROACH_TITLES)
        lines.append(f"| {distance} m | {cells} |")
    c = costs["material_ms_per_megapixel"]
    lines += [
        "",
        f"Material cost, ms per megapixel: close {c['close']:.1f}, far {c['far']:.1f}, full "
        f"{c['full']:.1f} (without skipping negligible close work {c['full_without_skip']:.1f})",
        f"Qt or OpenXR modules imported: {', '.join(results['modules_qt_or_xr']) or 'none'}; "
        f"{results['wall_s']:.0f} s in all",
    ]
    return "\n".join(lines)


def _no_plot(results: dict, path: str) -> None:
    raise ValueError("the GPU benchmark draws no plot; use --json")


def main(
    quick: bool = False,
    sizes=None,
    json_path: str | None = None,
    eye_scale: float | None = None,
    frames: int | None = None,
) -> int:
    results = run(quick=quick, sizes=sizes, eye_scale=eye_scale, frames=frames)
    return report(results, format_table, _no_plot, json_path)


def _eye_scale(text: str) -> float:
    value = number(text)
    if not (math.isfinite(value) and 0.001 <= value <= 2.0):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number from 0.001 to 2")
    return value


def _frames(text: str) -> int:
    value = integer(text)
    if not 1 <= value <= 10000:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number from 1 to 10000")
    return value


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        prog="python -m sand_editor.bench.gpu",
        description="sand-editor bench gpu, with the eye sizes scaled (tests, a first look)",
    )
    parser.add_argument("--quick", action="store_true", help="fewer frames, eyes half size")
    parser.add_argument("--sizes", type=integer, nargs="+", metavar="N", help="generator sizes")
    parser.add_argument("--json", help="write the results as JSON to this file")
    parser.add_argument("--eye-scale", type=_eye_scale, metavar="S", help="× each eye size")
    parser.add_argument("--frames", type=_frames, metavar="N", help="timed frames per eye size")
    args = parser.parse_args()
    raise SystemExit(main(args.quick, args.sizes, args.json, args.eye_scale, args.frames))
