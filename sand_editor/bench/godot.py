"""``sand-editor bench godot``: the Godot export's frames against the renderer's, drawn by
Godot 4 itself (Debian sid's, run by ``tools/godot/run``) on Mesa's CPU drivers.

Each shipped sand is exported (``export --format godot``), once as it is and once without glints,
and its demo scene draws the views ``bench web`` draws (16:30, pitch 25°, 0.3, 3 and 30 m, the
light's exposure, the editor's tone curve), with each of Godot's renderers: Compatibility
(OpenGL, on llvmpipe) and Forward+ (Vulkan, on lavapipe). Reported per view: FLIP of Godot's
frame against ours, the sparkle share of each and Godot's frame time (between two drawn frames;
the renderer's is to its pixels read back). Targets as bench web's.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image

from sand_editor.bench.browser import REPO
from sand_editor.bench.web import (
    PRESETS,
    SIZE,
    TEXTURE_SIZE,
    TIME,
    compare_port,
    port_results,
    port_table,
)
from sand_editor.export.godot import export_godot
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset

GODOT_RUN = REPO / "tools" / "godot" / "run"
DRIVERS = {"opengl3": "Compatibility", "vulkan": "Forward+"}
VIEWS_FILE = "bench-views.json"
SHOTS_DIR = "bench-shots"
# Godot's own report of a shader or GL failure (what a broken translation prints).
FAILURE = re.compile(r"SHADER ERROR|ERROR:|compilation failed", re.IGNORECASE)


def godot_view(camera, hours: float) -> dict:
    """A renderer camera as the demo scene's view: eye, camera-to-world axes, vertical field of
    view and planes (from the projection matrix, as Godot's Camera3D takes them)."""
    view = camera.view.astype(np.float64)
    axes = view[:3, :3].T  # columns: the camera's x, y, z in the world
    p = camera.projection.astype(np.float64)
    a, b = p[2, 2], p[2, 3]
    return {
        "eye": [float(v) for v in camera.eye],
        "basis": [float(v) for v in axes.T.reshape(-1)],
        "fov_y_deg": math.degrees(2.0 * math.atan(1.0 / p[1, 1])),
        "near": float(b / (a - 1.0)),
        "far": float(b / (a + 1.0)),
        "hours": float(hours),
    }


def godot_frames(
    project: Path, cameras, driver: str = "opengl3", size=SIZE, timeout_s: int = 600
) -> dict:
    """The exported project's demo drawing each (camera, hours) in Godot: ``frames`` (n, height,
    width, 3) uint8 top-down, ``ms`` per frame, ``info`` (Godot's renderer line and output)."""
    project = Path(project)
    (project / VIEWS_FILE).write_text(json.dumps([godot_view(c, h) for c, h in cameras]))
    width, height = size
    command = [
        str(GODOT_RUN), "--timeout", str(timeout_s), "--driver", driver,
        "--size", f"{width}x{height}", str(project), "--",
        "--views", f"res://{VIEWS_FILE}", "--capture", f"res://{SHOTS_DIR}",
    ]  # fmt: skip
    (project / SHOTS_DIR).mkdir(exist_ok=True)
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s + 60)
    output = done.stdout + done.stderr
    failures = [line for line in output.splitlines() if FAILURE.search(line)]
    if done.returncode != 0 or failures:
        raise RuntimeError(
            f"Godot exited {done.returncode} drawing {project}: "
            + ("; ".join(failures[:5]) or output[-2000:])
        )
    ms = [float(m) for m in re.findall(r"^SAND_CAPTURE \d+ \S+ ([\d.]+)$", output, re.MULTILINE)]
    frames = []
    for i in range(len(cameras)):
        image = Image.open(project / SHOTS_DIR / f"view-{i}.png").convert("RGB")
        if image.size != (width, height):
            raise RuntimeError(f"Godot drew view {i} at {image.size}, not {width}×{height}")
        frames.append(np.asarray(image))
    renderer = next((line for line in output.splitlines() if "Using Device" in line), "")
    return {"frames": np.stack(frames), "ms": ms, "info": {"renderer": renderer.strip()}}


def compare(preset: Preset, ctx, driver: str = "opengl3", distances=None, folder=None) -> dict:
    """``bench web``'s comparison with the Godot project for the page."""
    kwargs = {} if distances is None else {"distances": distances}
    return compare_port(
        preset,
        ctx,
        "godot",
        lambda variant, out: export_godot(variant, out, TEXTURE_SIZE, ctx=ctx),
        lambda project, cameras: godot_frames(project, cameras, driver),
        folder=folder,
        **kwargs,
    )


def run(quick: bool = False) -> dict:
    ctx = standalone_context()
    names = PRESETS[:1] if quick else PRESETS
    rows, renderers = [], {}
    for driver, name in DRIVERS.items():
        for preset in names:
            result = compare(Preset.load(bundled_preset(preset)), ctx, driver)
            rows += [{**row, "renderer": name} for row in result["rows"]]
            renderers[name] = result["info"]["renderer"]
    return port_results(ctx, rows, godot=renderers)


def format_table(results: dict) -> str:
    m = results["machine"]
    lines = [f"machine: {m['cpu_model']}, {m['cpu_count']} cores, {m['gl_renderer']}"]
    lines += [f"Godot {name}: {line}" for name, line in results["godot"].items()]
    lines += [
        f"Godot export vs renderer, {results['size'][0]}×{results['size'][1]}, pitch "
        f"{results['pitch_deg']:g}°, {TIME}, material {results['texture_size']}²",
    ]
    return "\n".join(
        lines + port_table(results["rows"], "godot", "Godot", ("renderer", "Godot renderer"))
    )


def main(quick: bool = False, json_path: str | None = None) -> int:
    from sand_editor.bench._report import report

    return report(run(quick), format_table, lambda results, path: None, json_path)


if __name__ == "__main__":
    sys.exit(main("--quick" in sys.argv))
