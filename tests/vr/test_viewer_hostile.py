"""The real viewer (desktop backend, under Xvfb) against hostile link input and a storm of
edits: every bad line gets one error line back and frames keep coming; hundreds of generation
edits at the editor's pace leave every kind of GL object and resident memory as they were."""

from __future__ import annotations

import json
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sand_editor.vr.link import MAX_LINE_BYTES, LinkError, decode, encode
from tests.vr.test_viewer_desktop import _edited, _Viewer, needs_display

pytestmark = needs_display

STRICT_UTF8 = {"LC_ALL": "C.UTF-8", "LANG": "C.UTF-8", "PYTHONUTF8": "0"}


def _shading_edit(seq: int) -> bytes:
    preset = _edited("hostile", **{"shading.sss": 0.1 + 0.001 * (seq % 500)})
    return encode("preset", preset=preset, seq=seq).encode()


def _deep_preset(depth: int) -> bytes:
    nested = "[" * depth + "]" * depth
    return b'{"type": "preset", "seq": 1, "preset": {"name": ' + nested.encode() + b"}}\n"


BAD_LINES = {
    "private type": b'{"type": "_invalid"}\n',
    "private type with a message": b'{"type": "_invalid", "message": "forged"}\n',
    "seq NaN": b'{"type": "preset", "seq": NaN, "preset": {}}\n',
    "seq 1e999": b'{"type": "preset", "seq": 1e999, "preset": {}}\n',
    "preset nested 987 deep": _deep_preset(987),
    "100 000 [": b"[" * 100_000 + b"\n",
    "4301 digits": b'{"type": "time", "hours": ' + b"1" * 4301 + b"}\n",
    "not UTF-8": b'{"type": "mode", "mode": "\xff\xfe"}\n',
    "over-long line": b'{"type": "mode", "mode": "' + b"x" * (MAX_LINE_BYTES + 5) + b'"}\n',
    "unknown type": b'{"type": "wave"}\n',
    "not an object": b"[1, 2, 3]\n",
    "mode of the wrong type": b'{"type": "mode", "mode": {"a": 1}}\n',
    "time of the wrong type": b'{"type": "time", "hours": [], "playing": "yes"}\n',
    "preset of the wrong type": b'{"type": "preset", "preset": "paper-default"}\n',
    "key with a newline": b'{"type": "x\\nTraceback (most recent call last):"}\n',
    "grains of the wrong type": b'{"type": "preset", "preset": {}, "grains": [1]}\n',
    "grains naming a path": (
        b'{"type": "preset", "preset": {}, "grains": {"shm": "../../etc/passwd", "size": 512}}\n'
    ),
}


@pytest.fixture(scope="module")
def viewer():
    v = _Viewer("--desktop", "--render-scale", "0.05", **STRICT_UTF8)
    v.expect(lambda m: m["type"] == "ready")
    yield v
    if v.proc.poll() is None:
        v.send("quit")
    v.finish(timeout=60)


def _alive(v) -> None:
    assert v.proc.poll() is None, f"the viewer ended: {v.proc.stderr.read()[-3000:]}"


@pytest.mark.parametrize("kind", list(BAD_LINES))
def test_each_kind_of_bad_line_gets_one_error_and_an_edit_still_applies(viewer, kind):
    viewer.seen.clear()
    viewer.send_raw(BAD_LINES[kind])
    error = viewer.expect(lambda m: m["type"] == "error", timeout=60)
    assert "\n" not in error["message"] and len(error["message"]) <= 300
    seq = 1000 + list(BAD_LINES).index(kind)
    viewer.send_raw(_shading_edit(seq))
    applied = viewer.expect(lambda m: m["type"] in ("applied", "error"), timeout=120)
    expected = {"type": "applied", "seq": seq, "ms": applied["ms"], "grains": "kept"}
    assert applied == expected, viewer.seen
    assert sum(m["type"] == "error" for m in viewer.seen) == 1, viewer.seen
    _alive(viewer)


def _not_quit(line: bytes) -> bytes:
    try:
        message = decode(line)
    except LinkError:
        return line
    return b'{"type": "wave"}\n' if message["type"] in ("quit", "preset") else line


json_texts = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=12,
).map(lambda value: json.dumps(value).encode())
messages = st.builds(
    lambda kind, fields: json.dumps({"type": kind, **fields}).encode(),
    st.sampled_from(["time", "mode", "preset", "quit", "_invalid", "", "state", "x\ny"]),
    st.dictionaries(
        st.sampled_from(["hours", "day_speed", "playing", "mode", "seq", "preset", "message"]),
        st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
        max_size=4,
    ),
)
lines = st.one_of(
    st.binary(max_size=200).map(lambda b: b.replace(b"\n", b" ")),
    json_texts,
    messages,
    st.sampled_from(list(BAD_LINES.values())).map(lambda b: b[:-1]),
).map(lambda b: _not_quit(b + b"\n"))

FUZZ_BATCHES = 100  # × 100 lines: 10 000 lines against one viewer


@settings(
    max_examples=FUZZ_BATCHES,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(batch=st.lists(lines, min_size=100, max_size=100))
def test_fuzzed_lines_never_end_the_viewer(viewer, batch):
    viewer.seen.clear()
    marker = f"sentinel-{time.monotonic_ns()}"
    viewer.send_raw(b"".join(batch) + encode("mode", mode=marker).encode())
    viewer.expect(lambda m: m["type"] == "error" and marker in m["message"], timeout=120)
    errors = sum(m["type"] == "error" for m in viewer.seen)
    assert errors <= len(batch) + 1, "at most one error line per line"
    assert all("\n" not in m.get("message", "") for m in viewer.seen)
    _alive(viewer)


def test_after_the_fuzz_an_edit_is_applied_and_the_viewer_quits_cleanly(viewer):
    viewer.seen.clear()
    viewer.send("mode", mode="full")
    viewer.send_raw(_shading_edit(99_999))
    viewer.expect(lambda m: m["type"] == "applied" and m["seq"] == 99_999, timeout=120)
    viewer.send("quit")
    assert viewer.expect(lambda m: m["type"] == "bye")["status"] == 0
    assert viewer.finish() == 0


@pytest.mark.slow
def test_300_generation_edits_at_the_editors_pace_leave_resources_flat(tmp_path):
    report_path = tmp_path / "report.json"
    viewer = _Viewer("--desktop", "--render-scale", "0.05", "--report", str(report_path))
    try:
        viewer.expect(lambda m: m["type"] == "ready")
        time.sleep(3.0)  # past the report's warm-up sample (frame 50)
        for seq in range(1, 301):
            threshold = 0.25 + 0.25 * (seq % 50) / 50
            edit = _edited(f"storm {seq}", **{"generation.threshold": threshold})
            viewer.send("preset", preset=edit, seq=seq)
            time.sleep(0.05)
        viewer.expect(lambda m: m["type"] == "applied" and m["seq"] == 300, timeout=300)
        viewer.send("quit")
        assert viewer.expect(lambda m: m["type"] == "bye", timeout=120)["status"] == 0
        assert viewer.finish() == 0
    finally:
        viewer.finish(timeout=5)
    report = json.loads(report_path.read_text())
    assert report["errors"] == []
    # Edits faster than grains are made: most are dropped unbuilt (or stopped at a band).
    assert report["grain_requests_superseded"] > 100
    print("resources", report["resources"], "superseded", report["grain_requests_superseded"])
    warm, end = report["resources"]["after_warm_up"], report["resources"]["end"]
    assert sum(warm["gl_objects"].values()) > 10
    for kind, count in warm["gl_objects"].items():
        assert abs(end["gl_objects"][kind] - count) <= 1, (kind, warm, end)
    assert end["resident_mb"] <= 1.10 * warm["resident_mb"], (warm, end)
