"""The ``sand-editor`` command: the editor by default, and headless subcommands."""

from __future__ import annotations

import argparse
import importlib
import math
import signal
import sys
import threading
from pathlib import Path

from sand_editor.preset import Preset, PresetError
from sand_editor.resources import bundled_preset
from sand_editor.untrusted import integer, number, printable, shorten

MAX_ERROR_CHARS = 500  # one line on stderr, whatever the input held
PROGRESS_WIDTH = 30
MIN_PATCH_M, MAX_PATCH_M = 0.01, 1000.0
COMMANDS = ("edit", "bake", "export", "serve", "render", "vr", "bench")
# Each benchmark: the module of sand_editor.bench whose main() runs it, and the options it takes
# besides --quick and --json.
BENCHMARKS = {
    "generator": ("generator", {"sizes", "plot"}),
    "render": ("render", {"plot"}),
    "appearance": ("sweep", {"plot"}),
    "depth": ("depth", {"plot"}),
    "relief": ("relief_reference", {"plot"}),
    "repetition": ("repetition", set()),
    "band": ("band", set()),
    "editor": ("editor", set()),
    "vr-link": ("vr_link", set()),
    "vr-runtime": ("vr_runtime", set()),
    "gpu": ("gpu", {"sizes"}),
    "export": ("export", set()),
    "web": ("web", set()),
    "godot": ("godot", set()),
}


# Formats written as a folder of files rather than one asset.
FOLDER_FORMATS = ("web", "godot")


class CommandError(Exception):
    """A user-facing failure: printed as one line, exit status 1, no traceback."""


def preset_path(text: str | None) -> Path:
    """The file a preset argument names: a path, or a bundled preset's name (``red-desert``)."""
    if text is None:
        return bundled_preset("paper-default")
    candidate = Path(text)
    if not candidate.exists() and candidate.suffix == "" and "/" not in text:
        try:
            return bundled_preset(text)
        except FileNotFoundError as exc:
            raise PresetError(f"{text}: no such file, and {exc}") from None
    return candidate


def _cmd_edit(args) -> int:
    from sand_editor.app import run_editor

    if args.tab is not None and args.screenshot is None:
        raise CommandError("--tab applies to --screenshot only")
    return run_editor(
        preset_path(args.preset), screenshot=args.screenshot, tab=args.tab or "albedo"
    )


def run_with_progress(steps, stream=None) -> None:
    """Run a job's steps, drawing a progress bar on a terminal (nothing when piped). Ctrl+C or
    SIGTERM stops it between steps, and nothing is written."""
    stream = sys.stderr if stream is None else stream
    shown = stream.isatty()
    try:
        for fraction, what in steps:
            if shown:
                filled = int(round(PROGRESS_WIDTH * fraction))
                bar = "█" * filled + "·" * (PROGRESS_WIDTH - filled)
                stream.write(f"\r{bar} {fraction * 100:3.0f}% {what:<28.28}")
                stream.flush()
    except KeyboardInterrupt:
        steps.close()
        if shown:
            stream.write("\n")
        print("cancelled: nothing was written", file=sys.stderr)
        raise
    if shown:
        stream.write("\r" + " " * (PROGRESS_WIDTH + 34) + "\r")
        stream.flush()


def _cmd_bake(args) -> int:
    from sand_editor.bake import DEFAULT_TARGET, BakeSteps
    from sand_editor.export.sets import MapFormats
    from sand_editor.generator import check_size

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise CommandError(f"{out}: is not a folder; --out names the folder to bake into")
    check_size(args.size)
    formats = None
    if args.normal_format or args.height_format:
        formats = MapFormats(
            normal=args.normal_format or "png8", height=args.height_format or "png16"
        )
    preset = Preset.load(preset_path(args.preset))
    steps = BakeSteps(preset, args.size, out, target=args.target, formats=formats)
    run_with_progress(steps)
    report = steps.record
    stats = report["statistics"]
    top = stats["coverage_per_layer"][0] if stats["coverage_per_layer"] else 0.0
    kind = "" if args.target == DEFAULT_TARGET else f" ({args.target} set)"
    print(
        f"baked {preset.name}{kind} at {args.size}² into {printable(args.out)}: top-layer "
        f"coverage {top:.3f}, gap fraction {stats['gap_fraction']:.3f}, "
        f"{stats['grain_count']} grains"
    )
    return 0


def export_size(fmt: str | None, size: int | None) -> int:
    """The texture size of an export: the one asked for, else the format's default (a glTF's
    maps are baked larger than the material a web page draws with)."""
    from sand_editor.generator.sizes import DEFAULT_EXPORT_SIZE, DEFAULT_RENDER_SIZE

    if size is not None:
        return size
    return DEFAULT_RENDER_SIZE if fmt in FOLDER_FORMATS else DEFAULT_EXPORT_SIZE


def _cmd_export(args) -> int:
    from sand_editor.export.gltf import PatchOptions
    from sand_editor.export.run import ExportSteps
    from sand_editor.generator import check_size

    if args.format in FOLDER_FORMATS:
        return _export_folder(args)
    size = export_size(args.format, args.size)
    check_size(size)
    if not (math.isfinite(args.patch) and MIN_PATCH_M <= args.patch <= MAX_PATCH_M):
        raise CommandError(f"--patch {args.patch}: allowed {MIN_PATCH_M} to {MAX_PATCH_M} metres")
    preset = Preset.load(preset_path(args.preset))
    options = PatchOptions(size_m=args.patch, sphere=args.sphere, tiles=args.tiles)
    steps = ExportSteps(preset, Path(args.out), args.format, size, options)
    run_with_progress(steps)
    record = steps.record
    count = len(record["files"])
    print(
        f"exported {preset.name} as {record['format']} ({count} file{'s' if count > 1 else ''}, "
        f"{record['bytes'] / 1e6:.1f} MB) to {printable(args.out)}"
    )
    return 0


def _export_folder(args) -> int:
    from sand_editor.generator import check_size

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise CommandError(
            f"{out}: is not a folder; with --format {args.format}, --out names a folder"
        )
    if args.tiles != 1:
        raise CommandError(
            f"--tiles applies to glb and gltf only; --format {args.format} draws the tile's "
            "varied copies in its shader"
        )
    size = export_size(args.format, args.size)
    check_size(size)
    preset = Preset.load(preset_path(args.preset))
    if args.format == "web":
        from sand_editor.export.web import export_web

        written, what = export_web(preset, out, size), "a web page"
        then = f"view it with: sand-editor serve {printable(args.out)}"
    else:
        from sand_editor.export.godot import export_godot

        written, what = export_godot(preset, out, size), "a Godot 4 project"
        then = "open its project.godot in Godot 4 (made for and tested with 4.6)"
    print(
        f"exported {preset.name} as {what} ({len(written)} files, "
        f"{sum(written.values()) / 1e6:.1f} MB) to {printable(args.out)}; {then}"
    )
    return 0


def _cmd_serve(args) -> int:
    from sand_editor.export.serve import serve

    return serve(Path(args.folder), args.host, args.port)


def _size_argument(text: str) -> tuple[int, int]:
    width, sep, height = text.lower().partition("x")
    try:
        size = (integer(width), integer(height)) if sep else None
    except ValueError:
        size = None
    if size is None or not (1 <= size[0] <= 8192 and 1 <= size[1] <= 8192):
        raise argparse.ArgumentTypeError(f"{text!r}: expected WIDTHxHEIGHT, each 1 to 8192")
    return size


def _cmd_render(args) -> int:
    from sand_editor.render.frame import render_frame

    preset = Preset.load(preset_path(args.preset))
    stats = render_frame(
        preset,
        Path(args.out),
        size=args.size,
        distance_m=args.distance,
        time_text=args.time,
        mode=args.mode,
        pitch_deg=args.pitch,
        sphere=args.sphere,
        samples=args.samples,
    )
    samples = f", {args.samples}×{args.samples} samples" if args.samples > 1 else ""
    print(
        f"rendered {preset.name} ({args.mode}) at {args.distance} m, {args.time}, "
        f"{args.size[0]}×{args.size[1]}{samples} into {printable(args.out)} "
        f"in {stats['ms']:.0f} ms"
    )
    return 0


def _samples(text: str) -> int:
    from sand_editor.render.still import MAX_STILL_SAMPLES, check_samples

    try:
        value = integer(text)
        check_samples(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected a whole number of samples a side from 1 to {MAX_STILL_SAMPLES}"
        ) from None
    return value


def _render_scale(text: str) -> float:
    try:
        value = number(text)
    except ValueError:
        value = float("nan")
    if not 0.05 <= value <= 4.0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number from 0.05 to 4")
    return value


def _day_speed(text: str) -> float:
    from sand_editor.view import MAX_DAY_SPEED

    try:
        value = number(text)
    except ValueError:
        value = float("nan")
    if not 0.0 <= value <= MAX_DAY_SPEED:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected simulated hours per second from 0 to {MAX_DAY_SPEED:g}"
        )
    return value


def _cmd_vr(args) -> int:
    from sand_editor.files import check_regular_target
    from sand_editor.render.sky import parse_time
    from sand_editor.vr.loop import ViewerOptions
    from sand_editor.vr.viewer import run_viewer

    path = preset_path(args.preset)
    if args.frames is not None and args.frames < 1:
        raise CommandError(f"--frames must be at least 1, got {args.frames}")
    for output in (args.report, args.screenshot):
        if output:
            check_regular_target(output)  # refused now, not after the session
    options = ViewerOptions(
        preset=Preset.load(path),
        preset_label=path.stem,
        hours=parse_time(args.time) % 24.0,
        day_speed=args.day_speed,
        mode=args.mode,
        frames=args.frames,
        texture_size=args.texture_size,
        screenshot=Path(args.screenshot) if args.screenshot else None,
        comfort=not args.no_comfort,
    )
    return run_viewer(
        options,
        desktop=args.desktop,
        control=args.control,
        report_path=Path(args.report) if args.report else None,
        render_scale=args.render_scale,
    )


def _cmd_bench(args) -> int:
    from sand_editor.bench import MissingPackage
    from sand_editor.files import OutputError, check_output

    for option, output in (("--json", args.json), ("--plot", args.plot)):
        try:
            if output:
                check_output(output)  # refused now, not after the run
        except OutputError as error:
            raise CommandError(f"{option} {error}") from None
    try:
        return _run_bench(args)
    except MissingPackage as error:  # the bench extra is not installed
        raise CommandError(str(error)) from None


def _run_bench(args) -> int:
    module_name, options = BENCHMARKS[args.what]
    refused = [
        f"--{name}" for name in ("sizes", "plot") if getattr(args, name) and name not in options
    ]
    if refused:
        verb = "does" if len(refused) == 1 else "do"
        raise CommandError(f"{' and '.join(refused)} {verb} not apply to the {args.what} benchmark")
    module = importlib.import_module(f"sand_editor.bench.{module_name}")
    chosen = {"quick": args.quick, "json_path": args.json}
    if "sizes" in options:
        chosen["sizes"] = args.sizes
    if "plot" in options:
        chosen["plot_path"] = args.plot
    return module.main(**chosen)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sand-editor",
        description="Design glinty sand materials. With no command, opens the editor.",
    )
    sub = parser.add_subparsers(dest="command")
    from sand_editor.generator.sizes import (
        DEFAULT_BAKE_SIZE,
        DEFAULT_EXPORT_SIZE,
        DEFAULT_RENDER_SIZE,
        SIZE_RANGE,
        VR_SIZES,
    )

    size_help = f"texture edge in pixels ({SIZE_RANGE})"

    edit = sub.add_parser("edit", help="open the editor (the default command)")
    edit.add_argument("preset", nargs="?", help="preset file or bundled preset name")
    edit.add_argument(
        "--screenshot",
        metavar="FILE",
        help="save a PNG of the window once it is completely drawn, then exit",
    )
    edit.add_argument(
        "--tab",
        choices=["albedo", "normals", "glint", "layers", "3d"],
        help="the preview tab shown in the screenshot (default albedo)",
    )
    edit.set_defaults(run=_cmd_edit)

    bake = sub.add_parser("bake", help="write a preset's grain textures as PNG files")
    bake.add_argument("preset", help="preset file or bundled preset name")
    bake.add_argument(
        "--size",
        type=integer,
        default=DEFAULT_BAKE_SIZE,
        help=size_help,
    )
    bake.add_argument("--out", required=True, help="output folder (created if missing)")
    from sand_editor.bake import DEFAULT_TARGET, TARGETS
    from sand_editor.export.images import FORMATS as MAP_FORMATS

    bake.add_argument(
        "--target",
        choices=TARGETS,
        default=DEFAULT_TARGET,
        help="whose texture set: ours (the default), or an engine's packing and conventions",
    )
    bake.add_argument(
        "--normal-format",
        choices=MAP_FORMATS,
        help="normal map file: 8- or 16-bit PNG, or float EXR (engine targets; default png8)",
    )
    bake.add_argument(
        "--height-format",
        choices=MAP_FORMATS,
        help="height map file (engine targets; default png16)",
    )
    bake.set_defaults(run=_cmd_bake)

    export = sub.add_parser(
        "export",
        help="write a sand patch as a glTF 2.0 asset (.glb, .gltf), or the sand as a web page "
        "or a Godot 4 project",
    )
    export.add_argument("preset", help="preset file or bundled preset name")
    export.add_argument(
        "--out", required=True, help="the .glb or .gltf file to write (web, godot: the folder)"
    )
    export.add_argument(
        "--format",
        choices=["glb", "gltf", *FOLDER_FORMATS],
        help="default: from --out's suffix; web: a WebGL2/WebXR page with the glints; godot: "
        "a Godot 4 project whose shader is the renderer's",
    )
    export.add_argument(
        "--size",
        type=integer,
        default=None,
        help=f"{size_help} (default {DEFAULT_EXPORT_SIZE}; web, godot {DEFAULT_RENDER_SIZE})",
    )
    export.add_argument("--patch", type=number, default=2.0, help="edge of the patch in metres")
    export.add_argument("--sphere", action="store_true", help="put the sand sphere on the patch")
    export.add_argument(
        "--tiles",
        type=integer,
        default=1,
        help="glb, gltf: tiles across the images, each place a copy of the tile turned and "
        "shifted, borders along the grains: the pattern repeats this many tiles apart instead "
        "of every tile (default 1; the images grow as many times wider)",
    )
    export.set_defaults(run=_cmd_export)

    serve = sub.add_parser("serve", help="serve an exported web page on this machine")
    serve.add_argument("folder", help="the folder export --format web wrote")
    serve.add_argument("--port", type=integer, default=8000, help="TCP port (default 8000)")
    serve.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine and adb reverse only)",
    )
    serve.set_defaults(run=_cmd_serve)

    from sand_editor.render.modes import MODES

    render = sub.add_parser("render", help="render one frame of the desert headless to a PNG")
    render.add_argument("preset", help="preset file or bundled preset name")
    render.add_argument("--out", required=True, help="PNG file to write")
    render.add_argument("--size", type=_size_argument, default=(1280, 720), help="WIDTHxHEIGHT")
    render.add_argument("--distance", type=number, default=1.0, help="metres from the sand")
    render.add_argument("--time", default="10:00", help="time of day, HH:MM")
    render.add_argument("--mode", choices=MODES, default="full", help="what to show")
    render.add_argument("--pitch", type=number, default=45.0, help="degrees below the horizon")
    render.add_argument("--sphere", action="store_true", help="put a sand sphere in view")
    render.add_argument(
        "--samples",
        type=_samples,
        default=1,
        help="samples a pixel on each axis, 1 to 8: K×K frames, each moved by a K-th of a pixel "
        "and filtering the sand as a frame K times larger does, averaged after the tone curve",
    )
    render.set_defaults(run=_cmd_render)

    vr = sub.add_parser("vr", help="view the sand in VR (OpenXR), or in a desktop stereo preview")
    vr.add_argument("preset", nargs="?", help="preset file or bundled preset name")
    vr.add_argument("--desktop", action="store_true", help="both eyes side by side in a window")
    vr.add_argument("--control", choices=["stdio"], help="take commands from the editor on stdin")
    vr.add_argument(
        "--frames", type=integer, metavar="N", help="submit this many frames, then exit"
    )
    vr.add_argument(
        "--report", metavar="FILE.json", help="write what ran and how fast as JSON to this file"
    )
    vr.add_argument(
        "--render-scale",
        type=_render_scale,
        default=1.0,
        metavar="S",
        help="× the recommended eye size",
    )
    vr.add_argument(
        "--time", default="10:00", metavar="HH:MM", help="time of day to start at, HH:MM"
    )
    vr.add_argument(
        "--day-speed",
        type=_day_speed,
        default=0.0,
        metavar="H",
        help="simulated hours per second (0: still)",
    )
    vr.add_argument("--mode", choices=MODES, default="full", help="what to show")
    vr.add_argument(
        "--texture-size",
        type=integer,
        choices=VR_SIZES,
        default=DEFAULT_RENDER_SIZE,
        metavar="N",
        help=f"grain texture size in pixels, one of {', '.join(map(str, VR_SIZES))}",
    )
    vr.add_argument(
        "--screenshot",
        metavar="FILE.png",
        help="save both eyes of the last frame side by side (PNG)",
    )
    vr.add_argument(
        "--no-comfort",
        action="store_true",
        help="no vignette over teleports and snap turns (the panel's comfort button toggles it)",
    )
    vr.set_defaults(run=_cmd_vr)

    bench = sub.add_parser("bench", help="measure speed against error")
    bench.add_argument(
        "what",
        choices=list(BENCHMARKS),
        help="what to measure",
    )
    bench.add_argument("--quick", action="store_true", help="fewer sizes and repeats")
    bench.add_argument(
        "--sizes",
        type=integer,
        nargs="+",
        metavar="N",
        help=f"texture sizes to measure ({SIZE_RANGE})",
    )
    bench.add_argument("--json", help="write the results as JSON to this file")
    bench.add_argument("--plot", help="draw the results into this PNG file")
    bench.set_defaults(run=_cmd_bench)
    return parser


def _terminated(signum, frame):
    # Unwinds like Ctrl+C, so that a half-written output's temporary file is removed.
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or (argv[0] not in {*COMMANDS, "-h", "--help"}):
        argv = ["edit", *argv]
    args = _parser().parse_args(argv)
    main_thread = threading.current_thread() is threading.main_thread()
    if args.command in ("bake", "export", "render") and main_thread:
        signal.signal(signal.SIGTERM, _terminated)
    try:
        return args.run(args)
    except (PresetError, CommandError, ValueError, OSError) as exc:
        message = shorten(printable(str(exc)), MAX_ERROR_CHARS)
        print(f"sand-editor {args.command}: error: {message}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
