"""The editor ↔ viewer link: message encoding and the stdio reader."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import threading
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sand_editor.vr import link
from sand_editor.vr.link import LinkError, StdioLink, check_time_fields, decode, encode


def test_encode_writes_one_json_line_and_decode_reads_it_back():
    line = encode("time", hours=16.5, day_speed=0.0, playing=False)
    assert line.endswith("\n") and line.count("\n") == 1
    assert decode(line) == {"type": "time", "hours": 16.5, "day_speed": 0.0, "playing": False}
    assert decode(encode("error", message="déjà vu").encode()) == {
        "type": "error",
        "message": "déjà vu",
    }


def test_encode_refuses_nan():
    with pytest.raises(ValueError):
        encode("time", hours=float("nan"))


@pytest.mark.parametrize(
    "line,reason",
    [("{", "not JSON"), ("[1, 2]", "JSON object"), ('{"kind": "x"}', "'type'")],
)
def test_decode_names_what_is_wrong(line, reason):
    with pytest.raises(LinkError, match=reason):
        decode(line)


def test_time_fields_are_checked():
    assert check_time_fields({"type": "time", "hours": 3}) == {"hours": 3.0}
    for bad, field in [
        ({"hours": 24.0}, "hours"),
        ({"hours": float("nan")}, "hours"),
        ({"day_speed": -1}, "day_speed"),
        ({"day_speed": True}, "day_speed"),
        ({"playing": 1}, "playing"),
    ]:
        with pytest.raises(LinkError, match=field):
            check_time_fields(bad)


def test_exit_statuses_are_distinct():
    statuses = [link.EXIT_OK, link.EXIT_BAD_INPUT, link.EXIT_NO_RUNTIME, link.EXIT_NO_HEADSET,
                link.EXIT_LINK_BROKEN,
                link.EXIT_GRAPHICS, link.EXIT_INTERRUPTED]  # fmt: skip
    assert statuses == [0, 1, 3, 4, 6, 5, 130]


def _wait_for(predicate, timeout=5.0):
    end = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.01)


def test_reader_queues_messages_and_sees_eof():
    read_fd, write_fd = os.pipe()
    reader_end = os.fdopen(read_fd, "r", encoding="utf-8")
    writer = os.fdopen(write_fd, "w", encoding="utf-8")
    out = io.StringIO()
    stdio = StdioLink(reader_end, out)
    assert stdio.poll() == []
    writer.write(encode("mode", mode="lambert") + "not json\n\n" + encode("quit"))
    writer.flush()
    received = []
    _wait_for(lambda: received.extend(stdio.poll()) or len(received) >= 3)
    assert received[0] == {"type": "mode", "mode": "lambert"}
    assert isinstance(received[1], LinkError) and "not JSON" in str(received[1])
    assert received[2] == {"type": "quit"}
    assert not stdio.closed
    writer.close()
    _wait_for(lambda: stdio.closed)


def test_the_start_up_sees_a_quit_or_an_eof_without_polling():
    # The viewer reads no messages while it starts; it asks quit_asked instead.
    read_fd, write_fd = os.pipe()
    writer = os.fdopen(write_fd, "w", encoding="utf-8")
    stdio = StdioLink(os.fdopen(read_fd, "r", encoding="utf-8"), io.StringIO())
    writer.write(encode("mode", mode="lambert"))
    writer.flush()
    time.sleep(0.2)
    assert not stdio.quit_asked  # other messages are not a quit
    writer.write(encode("quit"))
    writer.flush()
    _wait_for(lambda: stdio.quit_asked)
    assert not stdio.closed
    assert [m["type"] for m in stdio.poll()] == ["mode", "quit"]  # still queued for the loop
    writer.close()
    read_fd, write_fd = os.pipe()
    os.close(write_fd)  # the editor went away: EOF
    eof = StdioLink(os.fdopen(read_fd, "r", encoding="utf-8"), io.StringIO())
    _wait_for(lambda: eof.quit_asked and eof.closed)


def test_send_is_one_whole_line_per_message_from_many_threads():
    out = io.StringIO()
    stdio = StdioLink(io.StringIO(""), out)

    def talk(n):
        for i in range(200):
            stdio.send(type="time", hours=float(i % 24), day_speed=float(n), playing=True)

    threads = [threading.Thread(target=talk, args=(n,)) for n in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    lines = out.getvalue().splitlines()
    assert len(lines) == 800
    assert all(json.loads(line)["type"] == "time" for line in lines)


def test_link_module_imports_no_openxr_or_gl():
    code = (
        "import sys, sand_editor.vr.link; "
        "bad = [m for m in ('xr', 'moderngl', 'glfw', 'PySide6') if m in sys.modules]; "
        "print(bad); sys.exit(1 if bad else 0)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize(
    "line,reason",
    [
        (b'{"type": "mode", "mode": "\xff"}\n', "not UTF-8: byte 0xff"),
        (b"[" * 100_000 + b"\n", "nested more than"),
        (b'{"type": "preset", "seq": ' + b"9" * 4301 + b"}\n", "a number of 4301 characters"),
        (b'{"type": "x", "a": ' + b"[" * 30 + b"]" * 30 + b"}\n", "nested more than 16 deep"),
    ],
)
def test_decode_raises_only_link_error_for_hostile_lines(line, reason):
    with pytest.raises(LinkError, match=reason):
        decode(line)


@pytest.mark.parametrize("seq", [float("nan"), float("inf"), 1e999, -1, 2**60, True, "1", [1]])
def test_seq_must_be_a_small_integer(seq):
    with pytest.raises(LinkError, match="seq must be null or an integer"):
        link.check_seq({"type": "preset", "seq": seq})
    assert link.check_seq({"type": "preset", "seq": 7}) == 7
    assert link.check_seq({"type": "preset"}) is None


def test_reader_skips_an_over_long_line_and_reads_on():
    read_fd, write_fd = os.pipe()
    stdio = StdioLink(os.fdopen(read_fd, "rb"), io.StringIO())
    writer = os.fdopen(write_fd, "wb")

    def write():
        writer.write(b"[" * (link.MAX_LINE_BYTES + 10) + b"\n" + encode("quit").encode())
        writer.close()

    threading.Thread(target=write, daemon=True).start()
    received = []
    _wait_for(lambda: received.extend(stdio.poll()) or stdio.closed, timeout=30)
    received.extend(stdio.poll())
    assert len(received) == 2
    assert isinstance(received[0], LinkError) and "over" in str(received[0])
    assert received[1] == {"type": "quit"}
    assert stdio.broken is None


def test_a_read_error_marks_the_link_broken_not_closed_quietly():
    class Failing:
        def fileno(self):
            raise OSError("no descriptor")

        def __iter__(self):
            raise OSError(5, "Input/output error")

    stdio = StdioLink(Failing(), io.StringIO())
    _wait_for(lambda: stdio.closed)
    assert stdio.broken is not None and "Input/output error" in stdio.broken


def test_error_text_is_one_bounded_line():
    text = link.error_text("unknown message type 'a\nb\x1b" + "z" * 10_000 + "'")
    assert "\n" not in text and "\\n" in text and "\\x1b" in text
    assert len(text) <= link.MAX_ERROR_CHARS


@settings(max_examples=500, deadline=None, database=None)
@given(
    grains=st.none()
    | st.booleans()
    | st.integers()
    | st.text(max_size=20)
    | st.dictionaries(
        st.sampled_from(["shm", "size", "extra"]),
        st.none() | st.booleans() | st.integers(-10, 5000) | st.floats() | st.text(max_size=70),
        max_size=3,
    )
)
def test_grains_of_a_preset_message_are_a_name_and_a_size_or_one_link_error(grains):
    try:
        checked = link.check_grains({"type": "preset", "grains": grains})
    except LinkError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("grains")
        return
    if grains is None:
        assert checked is None
        return
    name, size = checked
    assert name == grains["shm"] and "/" not in name and size in link.SHARED_SIZES


def test_grains_name_a_segment_never_a_path():
    ok = {"type": "preset", "grains": {"shm": "psm_0a1b2c3d", "size": 512}}
    assert link.check_grains(ok) == ("psm_0a1b2c3d", 512)
    for name in ("../etc/passwd", "/psm_1", "", "a" * 65, "x y"):
        with pytest.raises(LinkError, match="grains.shm must be"):
            link.check_grains({"type": "preset", "grains": {"shm": name, "size": 512}})
    for size in (500, True, 512.5, "512", None):
        with pytest.raises(LinkError, match="grains.size must be one of"):
            link.check_grains({"type": "preset", "grains": {"shm": "psm_1", "size": size}})
