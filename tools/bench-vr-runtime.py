"""The VR viewer in a real OpenXR runtime, as the README's VR table measures it.

Runs ``sand-editor vr --control stdio --frames N --report`` inside ``tools/monado/run`` (Monado,
simulated headset and Windows Mixed Reality controllers), sends one preset edit over the link a
few seconds after the first frame so that new grains are made while frames are submitted, and
prints the report's figures as a table. Needs root (the harness's namespaces).

    .venv/bin/python tools/bench-vr-runtime.py [--frames N] [--edit-after S] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import queue
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from sand_editor.preset import Preset  # noqa: E402
from sand_editor.resources import bundled_preset  # noqa: E402
from sand_editor.vr.link import decode, encode  # noqa: E402

TIMEOUT_S = 500


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--edit-after", type=float, default=2.0, help="seconds after ready")
    parser.add_argument("--json", help="write the viewer's report here")
    args = parser.parse_args()

    # The report must be written where the harness's root sees it: inside the checkout.
    scratch = Path(tempfile.mkdtemp(prefix=".bench-vr-", dir=REPO))
    report_path = scratch / "report.json"
    command = [
        str(REPO / "tools/monado/run"), "--controllers", "wmr", "--timeout", str(TIMEOUT_S),
        "python", "-m", "sand_editor", "vr", "--control", "stdio",
        "--frames", str(args.frames), "--report", str(report_path),
    ]  # fmt: skip
    viewer = subprocess.Popen(
        command, cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    lines: queue.Queue = queue.Queue()

    def read() -> None:
        for line in viewer.stdout:
            lines.put(decode(line))
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()

    def expect(*types: str) -> dict:
        while True:
            message = lines.get(timeout=TIMEOUT_S)
            if message is None:
                raise SystemExit(f"bench-vr-runtime: the viewer ended before {types}")
            if message.get("type") in types:
                return message

    try:
        expect("ready")
        time.sleep(args.edit_after)
        edit = Preset.load(bundled_preset("red-desert")).replace(name="edited")
        viewer.stdin.write(encode("preset", preset=edit.to_dict(), seq=1))
        viewer.stdin.flush()
        applied = expect("applied", "error")
        expect("bye")
        viewer.communicate(timeout=120)
        report = json.loads(report_path.read_text())
    finally:
        if viewer.poll() is None:
            viewer.kill()
        for path in scratch.iterdir():
            path.unlink()
        scratch.rmdir()
    report["edit_applied"] = applied
    rows = [
        ("one eye, until drawn", report["eye_ms"]),
        ("the viewer's own work per frame", report["frame_overhead_ms"]),
        ("waiting on the runtime", report["wait_ms"]),
        ("gap between submitted frames", report["frame_gap_ms"]),
    ]
    print(f"{report['runtime']} · {report['system']} · {report['frames_submitted']} frames")
    print("| | median ms | p99 ms |\n| --- | ---: | ---: |")
    for name, stats in rows:
        print(f"| {name} | {stats['median']:.1f} | {stats['p99']:.1f} |")
    print(f"| longest gap while new grains were made | "
          f"{report['max_frame_gap_while_regenerating_ms']:.1f} | |")  # fmt: skip
    print(f"| edit received → on screen (`applied`) | {applied.get('ms', float('nan')):.0f} | |")
    print(f"errors: {report['errors'] or 'none'}; hands: {report['interaction_profiles']}")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return 0 if applied.get("type") == "applied" and not report["errors"] else 1


if __name__ == "__main__":
    sys.exit(main())
