"""The VR viewer in a real OpenXR runtime, as the README's VR table measures it.

Runs ``sand-editor vr --control stdio --frames N --report`` inside ``tools/monado/run`` (Monado,
simulated headset and Windows Mixed Reality controllers), sends one preset edit over the link a
few seconds after the first frame so that new grains are made while frames are submitted, and
prints the report's figures as a table. Needs a checkout (the harness is tools/monado, not part
of the package) and root (the harness's namespaces):

    sand-editor bench vr-runtime [--quick] [--json FILE]
"""

from __future__ import annotations

import json
import queue
import subprocess
import tempfile
import threading
import time
from pathlib import Path

from sand_editor.bench._report import write_json
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset
from sand_editor.vr.link import decode, encode

REPO = Path(__file__).resolve().parents[2]  # the checkout, in a source tree
HARNESS = REPO / "tools" / "monado" / "run"
TIMEOUT_S = 500
EDIT_AFTER_S = 2.0  # the edit comes this long after the first frame


def main(quick: bool = False, json_path: str | None = None) -> int:
    """300 frames (``quick``: 100), one edit 2 s after the first."""
    frames = 100 if quick else 300
    if not HARNESS.is_file():
        raise SystemExit(
            f"sand-editor bench vr-runtime: needs the OpenXR test harness {HARNESS} "
            "(a checkout of the repository, not an installed package)"
        )

    # The report must be written where the harness's root sees it: inside the checkout.
    scratch = Path(tempfile.mkdtemp(prefix=".bench-vr-", dir=REPO))
    report_path = scratch / "report.json"
    command = [
        str(HARNESS), "--controllers", "wmr", "--timeout", str(TIMEOUT_S),
        "python", "-m", "sand_editor", "vr", "--control", "stdio",
        "--frames", str(frames), "--report", str(report_path),
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
        time.sleep(EDIT_AFTER_S)
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
    if json_path:
        write_json(json_path, report)
    return 0 if applied.get("type") == "applied" and not report["errors"] else 1
