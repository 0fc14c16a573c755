"""``sand-editor bench web``: the web export's frames against the renderer's, in headless
Chromium (WebGL2 on SwiftShader).

Each shipped sand is exported (``export --format web``), once as it is and once without glints
(no clear grains), and drawn by the exported page at the same views the renderer draws here:
16:30, pitch 25°, at 0.3, 3 and 30 m, both at the light's exposure (the page's). Reported per
view: FLIP (NVIDIA's perceptual metric) of the page's frame against ours, and the sparkle share
(``sweep.sparkle_share``: pixels glints make at least twice as bright as their neighbourhood
and as the same pixel without glints) of each. Targets: FLIP ≤ FLIP_TARGET, the page's sparkle
share within SPARKLE_TOLERANCE of ours where ours is at least MIN_SPARKLE_SHARE.

Also timed, after a first frame that is not: the page's frames (ms, in Chromium on SwiftShader,
a CPU rasterizer like llvmpipe) and the renderer's, each to its pixels read back.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sand_editor.bench.browser import JS_TOOLS, column_major, run_page
from sand_editor.export.web import export_web
from sand_editor.gl import standalone_context
from sand_editor.preset import Preset
from sand_editor.render.camera import camera_at_distance
from sand_editor.render.exposure import light_exposure
from sand_editor.render.material import SandMaterial
from sand_editor.render.renderer import SandRenderer
from sand_editor.render.request import FrameRequest
from sand_editor.render.sky import parse_time, sky_at
from sand_editor.resources import bundled_preset

DISTANCES = (0.3, 3.0, 30.0)
TIME = "16:30"
PITCH_DEG = 25.0
SIZE = (320, 180)
TEXTURE_SIZE = 512
FLIP_TARGET = 0.1
SPARKLE_TOLERANCE = 0.25
MIN_SPARKLE_SHARE = 0.002  # below this a view shows too few sparkles to compare shares
PRESETS = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")
PAGE = "web-view.html"


def views(distances=DISTANCES, time_text: str = TIME, size=SIZE) -> list:
    """The renderer's cameras of the bench's views (the terrain's ground under the target)."""
    from sand_editor.render.terrain import DuneTerrain

    terrain = DuneTerrain()
    width, height = size
    hours = parse_time(time_text)
    return [
        (
            camera_at_distance(
                distance, PITCH_DEG, width / height,
                ground_height=lambda x, z: float(terrain.height(x, z)),
            ),
            hours,
        )
        for distance in distances
    ]  # fmt: skip


def page_frames(site: Path, cameras, size=SIZE, timeout_s: float = 600) -> dict:
    """The exported page in ``site`` drawing each (camera, hours): ``frames`` (n, height, width,
    3) uint8 top-down, ``ms`` per frame, and ``info`` (the WebGL renderer, whether 32-bit float
    textures filter, what the console said)."""
    width, height = size
    params = {
        "width": width,
        "height": height,
        "views": [
            {
                "view": column_major(camera.view, "view"),
                "projection": column_major(camera.projection, "projection"),
                "eye": [float(v) for v in camera.eye],
                "hours": float(hours),
            }
            for camera, hours in cameras
        ],
    }
    posts = run_page(
        f"/{PAGE}",
        {f"/{PAGE}": JS_TOOLS / PAGE},
        {"/site/": Path(site)},
        params,
        frozenset({"result", "info"}),
        "the web export's frames",
        size,
        timeout_s,
    )
    raw = np.frombuffer(posts["result"], dtype=np.uint8)
    if raw.size != len(cameras) * width * height * 4:
        raise RuntimeError(f"the page sent {raw.size} bytes for {len(cameras)} frames")
    frames = raw.reshape(len(cameras), height, width, 4)[:, ::-1, :, :3].copy()
    info = json.loads(posts["info"])
    return {"frames": frames, "ms": info.pop("ms", []), "info": info}


def renderer_frames(ctx, preset: Preset, cameras, size=SIZE, texture_size=TEXTURE_SIZE):
    """The renderer's frames of the same views at the light's exposure, with its ms each."""
    material = SandMaterial(ctx, texture_size)
    renderer = SandRenderer(ctx)
    try:
        material.update(preset)
        renderer.set_material(material)
        frames, ms = [], []
        first, hours = cameras[0]
        renderer.render_to_array(*size, FrameRequest(first, sky_at(hours), "full", exposure=1.0))
        for camera, hours in cameras:
            sky = sky_at(hours)
            request = FrameRequest(camera, sky, "full", exposure=light_exposure(sky))
            start = time.perf_counter()
            frames.append(renderer.render_to_array(*size, request))
            ms.append((time.perf_counter() - start) * 1e3)
        return np.stack(frames), ms
    finally:
        renderer.release()
        material.release()


def plain(preset: Preset) -> Preset:
    """The preset without glints: no clear grains (what a sparkle is measured against)."""
    return preset.replace(**{"shading.clear_grains": 0.0})


def compare(preset: Preset, ctx, distances=DISTANCES, time_text=TIME, folder=None) -> dict:
    """Both frames of each view, lit and without glints, and their FLIP and sparkle shares."""
    return compare_port(
        preset,
        ctx,
        "web",
        lambda variant, out: export_web(variant, out, TEXTURE_SIZE, ctx=ctx),
        page_frames,
        distances,
        time_text,
        folder,
    )


def compare_port(
    preset: Preset, ctx, port: str, export, frames, distances=DISTANCES, time_text=TIME, folder=None
) -> dict:
    """The views drawn by a port of the renderer (the web page, the Godot project) and by the
    renderer, lit and without glints: FLIP and sparkle shares per view. ``export(preset, out)``
    writes the port into the folder ``out``; ``frames(out, cameras)`` draws it ({"frames": (n,
    height, width, 3) uint8, "ms": per frame, "info": what the port said of itself})."""
    from sand_editor.bench.depth import flip_error
    from sand_editor.bench.sweep import sparkle_share

    cameras = views(distances, time_text)
    variants = {"lit": preset, "plain": plain(preset)}
    drawn = {}
    with tempfile.TemporaryDirectory(prefix=f"sand-{port}-", dir=folder) as tmp:
        for kind, variant in variants.items():
            export(variant, Path(tmp) / kind)
            drawn[kind] = frames(Path(tmp) / kind, cameras)
    ours = {kind: renderer_frames(ctx, variant, cameras) for kind, variant in variants.items()}
    rows = []
    for i, distance in enumerate(distances):
        port_lit, port_plain = drawn["lit"]["frames"][i], drawn["plain"]["frames"][i]
        our_lit, our_plain = ours["lit"][0][i], ours["plain"][0][i]
        rows.append({
            "preset": preset.name, "distance_m": distance, "time": time_text,
            "flip": flip_error(our_lit / 255.0, port_lit / 255.0),
            "sparkle_ours": sparkle_share(our_lit, our_plain),
            f"sparkle_{port}": sparkle_share(port_lit, port_plain),
            "ms_ours": ours["lit"][1][i],
            f"ms_{port}": drawn["lit"]["ms"][i] if drawn["lit"]["ms"] else None,
        })  # fmt: skip
    return {
        "rows": rows,
        "info": drawn["lit"]["info"],
        "frames": {"ours": ours["lit"][0], port: drawn["lit"]["frames"]},
    }


def sparkles_agree(row: dict, port: str = "web") -> bool:
    ours, web = row["sparkle_ours"], row[f"sparkle_{port}"]
    if ours < MIN_SPARKLE_SHARE:
        return web < MIN_SPARKLE_SHARE + SPARKLE_TOLERANCE * MIN_SPARKLE_SHARE
    return abs(web - ours) <= SPARKLE_TOLERANCE * ours


def run(quick: bool = False) -> dict:
    ctx = standalone_context()
    names = PRESETS[:1] if quick else PRESETS
    rows, info = [], {}
    for name in names:
        result = compare(Preset.load(bundled_preset(name)), ctx)
        rows += result["rows"]
        info = result["info"]
    return port_results(
        ctx, rows, browser=info.get("renderer"), float_linear=info.get("float_linear")
    )


def port_results(ctx, rows: list[dict], **port) -> dict:
    """A port bench's JSON: the machine, what the port said of itself, the views' settings, the
    targets and the rows."""
    from sand_editor.bench.generator import machine_description
    from sand_editor.bench.gpu import cpu_model

    return {
        "machine": {**machine_description(ctx), "cpu_model": cpu_model()},
        **port,
        "size": list(SIZE),
        "texture_size": TEXTURE_SIZE,
        "pitch_deg": PITCH_DEG,
        "targets": {"flip": FLIP_TARGET, "sparkle_tolerance": SPARKLE_TOLERANCE},
        "rows": rows,
    }


def format_table(results: dict) -> str:
    m = results["machine"]
    lines = [
        f"machine: {m['cpu_model']}, {m['cpu_count']} cores, {m['gl_renderer']}",
        f"browser: {results['browser']} (32-bit float filtering: {results['float_linear']})",
        f"web export vs renderer, {results['size'][0]}×{results['size'][1]}, pitch "
        f"{results['pitch_deg']:g}°, {TIME}, material {results['texture_size']}²",
    ]
    return "\n".join(lines + port_table(results["rows"], "web", "web"))


def port_table(rows: list[dict], port: str, label: str, first=None) -> list[str]:
    """The comparison's rows as a Markdown table and the verdict under it: ``label`` names the
    port's columns; ``first`` (key, heading), if any, a leading column of each row."""
    lead = f"| {first[1]} " if first else ""
    lines = [
        "",
        f"{lead}| sand | distance | FLIP | sparkle ours | sparkle {label} | ms ours | ms {label} |",
        "|---" * (8 if first else 7) + "|",
    ]
    for row in rows:
        port_ms = "–" if row[f"ms_{port}"] is None else f"{row[f'ms_{port}']:.0f}"
        lead = f"| {row[first[0]]} " if first else ""
        lines.append(
            f"{lead}| {row['preset']} | {row['distance_m']:g} m | {row['flip']:.3f} | "
            f"{row['sparkle_ours']:.4f} | {row[f'sparkle_{port}']:.4f} | {row['ms_ours']:.0f} | "
            f"{port_ms} |"
        )
    worst = max(row["flip"] for row in rows)
    agree = all(sparkles_agree(row, port) for row in rows)
    lines += [
        "",
        f"worst FLIP {worst:.3f} (target ≤ {FLIP_TARGET}); sparkle shares within "
        f"{SPARKLE_TOLERANCE:.0%}: {'yes' if agree else 'no'}",
    ]
    return lines


def main(quick: bool = False, json_path: str | None = None) -> int:
    from sand_editor.bench._report import report

    return report(run(quick), format_table, lambda results, path: None, json_path)


if __name__ == "__main__":
    sys.exit(main("--quick" in sys.argv))
