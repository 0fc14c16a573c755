"""The ``sand-editor`` command: the editor by default, and headless subcommands."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sand_editor.preset import Preset, PresetError
from sand_editor.resources import bundled_preset


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

    return run_editor(preset_path(args.preset))


def _cmd_bake(args) -> int:
    from sand_editor.bake import bake

    preset = Preset.load(preset_path(args.preset))
    report = bake(preset, args.size, Path(args.out))
    stats = report["statistics"]
    top = stats["coverage_per_layer"][0] if stats["coverage_per_layer"] else 0.0
    print(
        f"baked {preset.name} at {args.size}² into {args.out}: top-layer coverage {top:.3f}, "
        f"gap fraction {stats['gap_fraction']:.3f}, {stats['grain_count']} grains"
    )
    return 0


def _cmd_bench(args) -> int:
    if args.what == "generator":
        from sand_editor.bench.generator import main as bench_generator

        return bench_generator(
            quick=args.quick, sizes=args.sizes, json_path=args.json, plot_path=args.plot
        )
    raise CommandError(f"unknown benchmark {args.what!r}")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sand-editor",
        description="Design glinty sand materials. With no command, opens the editor.",
    )
    sub = parser.add_subparsers(dest="command")

    edit = sub.add_parser("edit", help="open the editor (the default command)")
    edit.add_argument("preset", nargs="?", help="preset file or bundled preset name")
    edit.set_defaults(run=_cmd_edit)

    bake = sub.add_parser("bake", help="write a preset's grain textures as PNG files")
    bake.add_argument("preset", help="preset file or bundled preset name")
    bake.add_argument("--size", type=int, default=2048, help="texture edge in pixels (64-4096)")
    bake.add_argument("--out", required=True, help="output folder (created if missing)")
    bake.set_defaults(run=_cmd_bake)

    bench = sub.add_parser("bench", help="measure speed against error")
    bench.add_argument("what", choices=["generator"], help="what to measure")
    bench.add_argument("--quick", action="store_true", help="fewer sizes and repeats")
    bench.add_argument(
        "--sizes", type=int, nargs="+", metavar="N", help="texture sizes to measure (64-4096)"
    )
    bench.add_argument("--json", help="write the results as JSON to this file")
    bench.add_argument("--plot", help="draw the results into this PNG file")
    bench.set_defaults(run=_cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or (argv[0] not in {"edit", "bake", "bench", "-h", "--help"}):
        argv = ["edit", *argv]
    args = _parser().parse_args(argv)
    try:
        return args.run(args)
    except (PresetError, CommandError, ValueError, OSError) as exc:
        print(f"sand-editor {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
