"""How long an edit in the editor takes to be on screen in the VR viewer.

Opens the editor window, starts the desktop stereo preview from it (the same process, link and
frame loop as a headset), makes edits through the preset model as a control would, and times
each from the edit to the viewer's "applied" answer. A generation edit's new grains are either
the editor's own tile, handed over in shared memory (``editor``), or made again by the viewer
(``viewer``, the editor's tiles not shared): both are run, at the editor's tile size. Their
generation time, measured apart on a headless context, is subtracted to give the link's own
share. Needs a display (run it under xvfb-run):

    xvfb-run -a sand-editor bench vr-link [--quick] [--json FILE]

It drives Qt, so it lives with the editor; only the bench command runs it.
"""

from __future__ import annotations

import statistics
import sys
import time

from sand_editor.bench._report import write_json

READY_TIMEOUT_S = 180.0
APPLIED_TIMEOUT_S = 60.0
SETTLE_S = 0.3  # between edits, so each is timed alone


def _wait(app, condition, timeout_s: float, what: str) -> None:
    deadline = time.perf_counter() + timeout_s
    while not condition():
        if time.perf_counter() > deadline:
            raise SystemExit(f"sand-editor bench vr-link: timed out waiting for {what}")
        app.processEvents()
        time.sleep(0.002)


def _edits(window, kind: str, count: int):
    """``count`` edits of one kind: values that alternate, so each one changes the preset."""
    preset = window.model.preset
    for i in range(count):
        if kind == "shading":
            # A uniform of the material: no new grains, no texture rebuild.
            base = preset.shading.facet_roughness
            yield "shading.facet_roughness", base + (0.01 if i % 2 == 0 else 0.0)
        else:
            yield "generation.seed", preset.generation.seed + i + 1


def _measure_link(app, window, kinds, count: int) -> dict:
    link = window.vr.link
    viewer_ms: dict[int, float] = {}
    sources: dict[int, str] = {}

    def applied(seq: int, ms: float) -> None:
        viewer_ms[seq] = ms
        sources[seq] = link.applied_grains

    link.applied.connect(applied)
    results = {}
    for kind in kinds:
        rows = []
        for path, value in _edits(window, kind, count):
            seq_before = link.seq
            window.model.edit(path, value)
            _wait(app, lambda s=seq_before: link.seq > s, 5.0, "the edit to be sent")
            seq = link.seq
            _wait(app, lambda s=seq: s in viewer_ms, APPLIED_TIMEOUT_S, f"applied {seq}")
            rows.append(
                {
                    "seq": seq,
                    "edit_to_screen_ms": link.latency_ms[seq],
                    "viewer_ms": viewer_ms[seq],
                    "grains": sources[seq],
                }
            )
            settle = time.perf_counter() + SETTLE_S
            _wait(app, lambda t=settle: time.perf_counter() > t, SETTLE_S + 1, "settling")
        results[kind] = rows
    return results


def _generation_ms(preset, count: int, size: int) -> list[float]:
    """Grains plus material textures for new seeds, as the viewer's worker makes them."""
    from sand_editor.gl import standalone_context
    from sand_editor.render.material import SandMaterial

    ctx = standalone_context()
    material = SandMaterial(ctx, size)
    material.update(preset)
    ctx.finish()
    times = []
    for i in range(count):
        changed = preset.replace(**{"generation.seed": preset.generation.seed + 1000 + i})
        start = time.perf_counter()
        material.update(changed)
        ctx.finish()
        times.append((time.perf_counter() - start) * 1e3)
    material.release()
    return times


def _summary(values: list[float]) -> dict:
    ordered = sorted(values)
    return {
        "median": statistics.median(ordered),
        "p90": ordered[min(len(ordered) - 1, round(0.9 * (len(ordered) - 1)))],
        "max": ordered[-1],
    }


def _run_viewer(app, window, render_scale: float, edits: int, share: bool) -> tuple[dict, dict]:
    """Start the desktop preview from the window (handing it the editor's tiles or not), time
    the edits, close it."""
    link = window.vr.link
    size = window.regenerator.size
    link.extra_args = ("--render-scale", f"{render_scale:g}", "--texture-size", str(size))
    link.share_tiles = share
    window.vr.start(desktop=True)
    _wait(app, lambda: link.is_ready or not link.running, READY_TIMEOUT_S, "the first frame")
    if not link.is_ready:
        raise SystemExit(
            "sand-editor bench vr-link: the viewer did not start:\n" + link.stderr_tail()
        )
    info = link.ready_info
    try:
        return info, _measure_link(app, window, ("shading", "generation"), edits)
    finally:
        link.stop()
        _wait(app, lambda: not link.running, 10.0, "the viewer to close")


def _table_rows(
    info: dict, scale: float, share: bool, link_rows: dict, generation_ms: float
) -> list[dict]:
    eye = info["views"][0]
    table = []
    for kind, rows in link_rows.items():
        total = [row["edit_to_screen_ms"] for row in rows]
        viewer = [row["viewer_ms"] for row in rows]
        subtract = generation_ms if kind == "generation" else 0.0
        table.append(
            {
                "render_scale": scale,
                "eye": f"{eye['width']}×{eye['height']}",
                "edit": kind,
                "tiles_shared": share,
                "grains": "/".join(sorted({row["grains"] for row in rows})),
                "edits": len(rows),
                "edit_to_screen_ms": _summary(total),
                "edit_to_viewer_ms": _summary([t - v for t, v in zip(total, viewer, strict=True)]),
                "in_viewer_ms": _summary(viewer),
                "generation_ms": subtract,
                "minus_generation_ms": _summary([t - subtract for t in total]),
            }
        )
    return table


def _print_table(system: str, size: int, table: list[dict]) -> None:
    print(f"viewer: {system}, grains {size}²; median / p90 ms")
    print(
        "| eye | edit | grains from | edits | edit → on screen | editor → viewer | in the viewer "
        "| generation (apart) | on screen minus generation |"
    )
    print("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for row in table:
        cells = [
            f"{row[key]['median']:.0f} / {row[key]['p90']:.0f}"
            for key in ("edit_to_screen_ms", "edit_to_viewer_ms", "in_viewer_ms")
        ]
        net = row["minus_generation_ms"]
        print(
            f"| {row['eye']} | {row['edit']} | {row['grains']} | {row['edits']} | "
            f"{' | '.join(cells)} | {row['generation_ms']:.0f} | "
            f"**{net['median']:.0f}** / {net['p90']:.0f} |"
        )


def main(quick: bool = False, json_path: str | None = None) -> int:
    """10 edits of each kind at eye sizes 0.1 and 0.5 of 480×360, with the editor's tiles
    handed over and without (``quick``: 3 edits, 0.1)."""
    edits, render_scales = (3, [0.1]) if quick else (10, [0.1, 0.5])
    from sand_editor.app import require_display

    require_display()
    from PySide6.QtWidgets import QApplication

    from sand_editor.app import EditorWindow
    from sand_editor.preset import Preset
    from sand_editor.resources import bundled_preset

    app = QApplication.instance() or QApplication(sys.argv[:1])
    window = EditorWindow(Preset.load(bundled_preset("paper-default")))
    window.show()
    _wait(app, lambda: window.preview.textures is not None, READY_TIMEOUT_S, "the editor")
    runs = [
        (scale, share, *_run_viewer(app, window, scale, edits, share))
        for scale in render_scales
        for share in (True, False)
    ]
    size = window.regenerator.size
    generation = _generation_ms(window.model.preset, edits, size)
    table = [
        row
        for scale, share, info, link_rows in runs
        for row in _table_rows(info, scale, share, link_rows, statistics.median(generation))
    ]
    _print_table(runs[0][2]["system"], size, table)
    if json_path:
        document = {
            "viewer": runs[0][2]["system"],
            "texture_size": size,
            "generation_ms": generation,
            "runs": [
                {"render_scale": scale, "tiles_shared": share, "ready": info, "edits": link_rows}
                for scale, share, info, link_rows in runs
            ],
            "summary": table,
        }
        write_json(json_path, document)
    window.model.undo_stack.setClean()
    window.close()
    return 0
