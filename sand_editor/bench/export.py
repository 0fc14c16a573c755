"""``sand-editor bench export``: what an export costs, step by step — the engine texture sets at
2048² with EXR normals (the target: under 3 s), and the glTF asset — timed through the same
steps the command runs (generation, maps, encoding, the atomic write)."""

from __future__ import annotations

import shutil
import statistics
import tempfile
import time
from pathlib import Path

from sand_editor.bake import BakeSteps
from sand_editor.bench._report import report
from sand_editor.bench.generator import machine_description
from sand_editor.bench.gpu import cpu_model
from sand_editor.export.run import ExportSteps
from sand_editor.export.sets import TARGETS, MapFormats
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

# A step's label says what comes next: the time from one label to the next is that step's.
_PHASES = {
    "Generating the grains": "generate",
    "Making the material maps": "maps",
    "Encoding the images": "encode",
}


def _timed(steps) -> dict:
    phases: dict[str, float] = {}
    start = last = time.perf_counter()
    current = "generate"  # setting up counts with the generation
    for _, what in steps:
        now = time.perf_counter()
        phases[current] = phases.get(current, 0.0) + (now - last)
        last = now
        current = "write" if what.startswith("Writing") else _PHASES.get(what, "end")
    phases["total"] = time.perf_counter() - start
    return phases


def run(quick: bool = False) -> dict:
    ctx = standalone_context()
    preset = Preset.load(bundled_preset("paper-default"))
    size = 512 if quick else 2048
    repeats = 1 if quick else 3
    scratch = Path(tempfile.mkdtemp(prefix="sand-editor-bench-export-"))
    rows = []
    try:
        # One untimed run compiles the generator's program and fills the caches.
        for _ in BakeSteps(preset, 64, scratch / "warm", target="gltf"):
            pass
        jobs = [(f"bake --target {t} (EXR normals)", "bake", t) for t in TARGETS]
        jobs += [(f"export --format {f}", "export", f) for f in ("glb", "gltf")]
        for label, kind, job in jobs:
            runs = []
            for i in range(repeats):
                out = scratch / f"{kind}-{job}-{i}"
                if kind == "export":
                    steps = ExportSteps(preset, out / f"sand.{job}", size=size)
                else:
                    steps = BakeSteps(
                        preset, size, out, target=job, formats=MapFormats(normal="exr")
                    )
                runs.append(_timed(steps))
                size_bytes = sum(p.stat().st_size for p in out.iterdir())
                shutil.rmtree(out)
            row = {k: statistics.median(r.get(k, 0.0) for r in runs) for k in runs[0]}
            rows.append({"job": label, "size": size, "megabytes": size_bytes / 1e6,
                         "seconds": row})  # fmt: skip
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    machine = {**machine_description(ctx), "cpu_model": cpu_model()}
    return {"machine": machine, "preset": preset.name, "repeats": repeats, "rows": rows}


def format_table(results: dict) -> str:
    m = results["machine"]
    lines = [
        f"Export of {results['preset']} (median of {results['repeats']}), seconds — "
        f"{m['cpu_model']}, {m['cpu_count']} cores, {m['gl_renderer']}",
        "",
        "| job | size | generate | maps | encode | write | total | MB |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in results["rows"]:
        s = row["seconds"]
        cells = [f"{s.get(k, 0.0):.2f}" for k in ("generate", "maps", "encode", "write", "total")]
        cells.append(f"{row['megabytes']:.1f}")
        lines.append(f"| {row['job']} | {row['size']}² | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(quick: bool = False, json_path: str | None = None) -> int:
    return report(run(quick), format_table, lambda r, p: None, json_path)
