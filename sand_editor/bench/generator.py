"""``sand-editor bench generator``: speed against error of the grain generators, side by side.

Rows, all on the same moderngl context in one run:

- ``ours-gl``: the GLSL generator, textures left on the GPU (what the preview uses), and with the
  read-back to numpy;
- ``ours-reference``: the float64 numpy backend (the oracle's own code, timed as a backend);
- ``reference-port``: the reference's algorithm ported faithfully to GLSL.

Normal errors are measured against float64 evaluations of each row's own function with exact
gradients, at a fixed random sample of pixels, over pixels whose owning layer agrees. The port is
measured twice: against its function as written (float64 sine hash), and against the same function
with the hash rounded as a float32 GPU rounds it, which isolates the finite-difference error.
"""

from __future__ import annotations

import platform
import statistics
import sys
import time

import numpy as np

from sand_editor.bench._optional import pyplot
from sand_editor.bench._reference_port import ReferenceParams, ReferencePort, port_oracle
from sand_editor.bench._report import report
from sand_editor.generator import check_size, generate, gl_generator
from sand_editor.generator.noise import NoiseConstants
from sand_editor.generator.reference import evaluate
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

SIZES = (256, 512, 1024, 2048)
QUICK_SIZES = (256, 512)
ORACLE_SAMPLES = 20000
TARGET_SIZE = 1024


def _median_seconds(run, repeats: int) -> float:
    run()  # warm-up: shader compilation and first allocations are not what we measure
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _sample_pixels(size: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(size)
    flat = rng.choice(size * size, size=min(count, size * size), replace=False)
    ys, xs = np.divmod(flat, size)
    return xs, ys


def normal_errors(normal, layer, oracle_normal, oracle_layer) -> dict:
    """Angular error (degrees) over pixels whose owning layer agrees, and the layer mismatch."""
    agree = layer == oracle_layer
    a = np.asarray(normal, dtype=np.float64)[agree]
    b = np.asarray(oracle_normal, dtype=np.float64)[agree]
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    cos = np.clip(np.sum(a * b, axis=1), -1.0, 1.0)
    # arctan2 of |a×b| and a·b keeps precision for tiny angles, where arccos(cos) loses it.
    angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), cos))
    return {
        "normal_err_mean_deg": float(angle.mean()) if angle.size else float("nan"),
        "normal_err_p999_deg": float(np.percentile(angle, 99.9)) if angle.size else float("nan"),
        "share_over_1deg": float((angle > 1.0).mean()) if angle.size else float("nan"),
        "layer_mismatch": float(1.0 - agree.mean()),
    }


def _ours(ctx, preset: Preset, size: int, repeats: int, with_reference: bool) -> dict:
    nc = NoiseConstants.from_generation(preset.generation)
    generator = gl_generator(ctx)
    target = generator.allocate(size)

    def gpu_only():
        generator.render(nc, size, target)
        ctx.finish()

    rows = {}
    gpu_s = _median_seconds(gpu_only, repeats)
    readback_s = _median_seconds(lambda: generate(preset, size, ctx=ctx), repeats)
    textures = generate(preset, size, ctx=ctx)
    target.release()
    xs, ys = _sample_pixels(size, ORACLE_SAMPLES)
    oracle = evaluate(nc, size, xs, ys)
    errors = normal_errors(
        textures.normal[ys, xs], textures.layer[ys, xs], oracle["normal"], oracle["layer"]
    )
    rows["ours-gl"] = {"median_s": gpu_s, "median_with_readback_s": readback_s, **errors}
    if with_reference:
        ref_s = _median_seconds(lambda: generate(preset, size, backend="reference"), 1)
        ref = generate(preset, size, backend="reference")
        errors = normal_errors(
            ref.normal[ys, xs], ref.layer[ys, xs], oracle["normal"], oracle["layer"]
        )
        rows["ours-reference"] = {"median_s": ref_s, **errors}
    return rows, textures


def _port(ctx, port: ReferencePort, params: ReferenceParams, size: int, repeats: int) -> dict:
    def run():
        port.render(params, size)
        ctx.finish()

    seconds = _median_seconds(run, repeats)
    out = port.read()
    xs, ys = _sample_pixels(size, ORACLE_SAMPLES)
    rows = {}
    for name, precision in (("reference-port", "float64"), ("reference-port-fd-only", "float32")):
        oracle = port_oracle(params, size, xs, ys, hash_precision=precision)
        errors = normal_errors(
            out["normal"][ys, xs], out["layer"][ys, xs], oracle["normal"], oracle["layer"]
        )
        rows[name] = {"median_s": seconds, **errors}
    return rows, out


def count_regions(key: np.ndarray, mask: np.ndarray) -> int:
    """Connected regions of equal ``key`` within ``mask`` (4-neighbours, wrapping: tiles repeat)."""
    n = mask.size
    labels = np.where(mask, np.arange(n).reshape(mask.shape), n)
    while True:
        merged = labels
        for axis in (0, 1):
            for shift in (1, -1):
                same = mask & np.roll(mask, shift, axis) & (np.roll(key, shift, axis) == key)
                merged = np.minimum(merged, np.where(same, np.roll(labels, shift, axis), n))
        if np.array_equal(merged, labels):
            return int(np.unique(labels[mask]).size)
        labels = merged


def look_statistics(layer: np.ndarray, grain_key: np.ndarray, layers: int) -> dict:
    """Coverage of the top two layers, gap fraction, and the number and size of top grains."""
    total = layer.size
    top = layer == 0
    grains = count_regions(grain_key, top)
    return {
        "coverage_top": float(top.sum()) / total,
        "coverage_second": float((layer == 1).sum()) / total if layers > 1 else 0.0,
        "gap_fraction": float((layer < 0).sum()) / total,
        "top_layer_grains": grains,
        "top_grain_area_px": float(top.sum()) / max(grains, 1),
    }


def machine_description(ctx) -> dict:
    return {
        "gl_renderer": ctx.info.get("GL_RENDERER", "?"),
        "gl_version": ctx.info.get("GL_VERSION", "?"),
        "cpu": platform.processor() or platform.machine(),
        "cpu_count": __import__("os").cpu_count(),
        "python": platform.python_version(),
    }


def run(quick: bool = False, sizes=None, preset: Preset | None = None) -> dict:
    ctx = standalone_context()
    preset = preset if preset is not None else Preset.load(bundled_preset("paper-default"))
    params = ReferenceParams.from_preset(preset)
    port = ReferencePort(ctx)
    sizes = [check_size(s) for s in sizes] if sizes else (QUICK_SIZES if quick else SIZES)
    repeats = 3 if quick else 7
    results: dict = {
        "machine": machine_description(ctx),
        "preset": preset.name,
        "layers": preset.generation.layers,
        "sizes": {},
        "speedup_vs_reference_port": {},
    }
    for size in sizes:
        port_repeats = max(1, min(repeats, int(3e6 // (size * size))))
        rows, textures = _ours(ctx, preset, size, repeats, with_reference=size <= 1024)
        port_rows, port_out = _port(ctx, port, params, size, port_repeats)
        rows.update(port_rows)
        results["sizes"][str(size)] = rows
        results["speedup_vs_reference_port"][str(size)] = (
            rows["reference-port"]["median_s"] / rows["ours-gl"]["median_s"]
        )
        if size == min(sizes, key=lambda s: abs(s - 512)):
            layers = preset.generation.layers
            # The port's grains are told apart by their random scalar (its glint value), ours by
            # their grain word; neighbouring pixels with the same one form one grain.
            results["look_size"] = size
            results["look"] = {
                "reference-port": look_statistics(
                    port_out["layer"], port_out["glint"].view(np.int32), layers
                ),
                "ours": look_statistics(textures.layer, textures.grain_id, layers),
            }
        print(f"  measured {size}²", file=sys.stderr, flush=True)
    port.release()
    return results


ROW_TITLES = {
    "ours-gl": "ours, GL",
    "ours-reference": "ours, numpy float64",
    "reference-port": "reference port, GL",
    "reference-port-fd-only": "  same, finite differences only",
}


def format_table(results: dict) -> str:
    lines = [
        f"Generator, preset {results['preset']} ({results['layers']} layers), "
        f"{results['machine']['gl_renderer']}",
        "",
        "| size | generator | median ms | + read-back ms | normal err mean ° | p99.9 ° "
        "| >1° | layer mismatch |",
        "| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for size, rows in results["sizes"].items():
        for key, title in ROW_TITLES.items():
            if key not in rows:
                continue
            r = rows[key]
            readback = r.get("median_with_readback_s")
            lines.append(
                f"| {size}² | {title} | {r['median_s'] * 1e3:.1f} | "
                f"{'' if readback is None else f'{readback * 1e3:.1f}'} | "
                f"{r['normal_err_mean_deg']:.2g} | {r['normal_err_p999_deg']:.2g} | "
                f"{r['share_over_1deg'] * 100:.2g} % | {r['layer_mismatch'] * 100:.2g} % |"
            )
    lines.append("")
    speedups = ", ".join(
        f"{size}²: {value:.0f}×" for size, value in results["speedup_vs_reference_port"].items()
    )
    lines.append(f"Speed-up of ours (GL) over the reference port: {speedups}")
    look = results.get("look")
    if look:
        lines += [
            "",
            f"| sand statistics at {results['look_size']}² | reference port | ours |",
            "| --- | ---: | ---: |",
        ]
        for key in look["ours"]:
            a, b = look["reference-port"][key], look["ours"][key]
            fmt = "{:.3f}" if isinstance(a, float) else "{}"
            lines.append(f"| {key.replace('_', ' ')} | {fmt.format(a)} | {fmt.format(b)} |")
    return "\n".join(lines)


def plot(results: dict, path: str) -> None:
    """Time against size, and normal error against time, per generator."""
    plt = pyplot()
    fig, (ax_time, ax_err) = plt.subplots(1, 2, figsize=(11, 4.2))
    sizes = [int(s) for s in results["sizes"]]
    for key, title in ROW_TITLES.items():
        measured = [(s, results["sizes"][str(s)].get(key)) for s in sizes]
        measured = [(s, r) for s, r in measured if r is not None]
        if not measured:
            continue
        ms = [r["median_s"] * 1e3 for _, r in measured]
        if key != "reference-port-fd-only":
            ax_time.plot([s for s, _ in measured], ms, marker="o", label=title)
        errors = [max(r["normal_err_p999_deg"], 1e-6) for _, r in measured]
        ax_err.scatter(ms, errors, label=title.strip())
    ax_time.set(xscale="log", yscale="log", xlabel="texture edge (px)", ylabel="median time (ms)")
    ax_time.set_xticks(sizes, [str(s) for s in sizes])
    ax_time.minorticks_off()
    ax_time.set_title("Speed")
    ax_time.legend()
    ax_err.set(xscale="log", yscale="log", xlabel="median time (ms)")
    ax_err.set(ylabel="normal error, 99.9th percentile (°)")
    ax_err.set_title("Speed against error (every size)")
    ax_err.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(
    quick: bool = False,
    sizes=None,
    json_path: str | None = None,
    plot_path: str | None = None,
) -> int:
    if plot_path:
        pyplot()  # before the run, so that a missing matplotlib is said at once
    return report(run(quick=quick, sizes=sizes), format_table, plot, json_path, plot_path)
