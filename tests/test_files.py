"""Outputs are regular files written whole or not at all (sand_editor.files), for real: killed
writers, concurrent writers into one folder, devices and FIFOs, a full disk."""

from __future__ import annotations

import os
import random
import resource
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from sand_editor.files import (
    MAX_STEM_BYTES,
    OutputError,
    check_output,
    file_stem,
    remove_stray_temporaries,
    write_atomic,
    write_folder,
)
from sand_editor.preset import Preset, PresetError

REPO = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(REPO))


def _python(code: str, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", code], cwd=REPO, env=ENV, **kwargs)


def test_a_fifo_or_folder_is_refused_and_left_as_it_was(tmp_path):
    fifo = tmp_path / "pipe.png"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match=r"pipe\.png: is a FIFO; allowed a regular file"):
        write_atomic(fifo, b"data")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    folder = tmp_path / "out.png"
    folder.mkdir()
    with pytest.raises(OutputError, match="is a folder"):
        write_atomic(folder, b"data")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png", "pipe.png"]


def test_check_output_refuses_now_what_a_write_would_refuse_later(tmp_path):
    check_output(tmp_path / "new" / "deeper" / "results.json")  # folders are made on writing
    (tmp_path / "a-file").write_text("kept")
    with pytest.raises(OutputError, match="a-file/results.json: cannot write: Not a directory"):
        check_output(tmp_path / "a-file" / "results.json")
    with pytest.raises(OutputError, match="is a folder"):
        check_output(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write in any folder")
def test_check_output_refuses_a_folder_it_cannot_write_in(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o555)
    with pytest.raises(OutputError, match="is not writable"):
        check_output(locked / "new" / "results.json")


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize(
    "args",
    [
        ["render", "paper-default", "--size", "16x16", "--out", "/dev/full"],
        ["vr", "--desktop", "--frames", "1", "--report", "/dev/full"],
    ],
)
def test_the_cli_refuses_a_device_as_output_and_keeps_it(args):
    result = subprocess.run(
        [sys.executable, "-m", "sand_editor", *args],
        cwd=REPO, env=ENV, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 1, result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert "/dev/full: is a character device; allowed a regular file" in result.stderr
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_a_write_that_fails_names_the_file_and_keeps_the_old_one(tmp_path):
    path = tmp_path / "sand.json"
    Preset(name="old").save(path)
    old = path.read_bytes()

    def small_files():  # the disk is as full as an 80-byte file limit makes it
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (80, 80))

    code = (
        "import sys; from sand_editor.preset import Preset, PresetError\n"
        "try:\n    Preset(name='new').save(sys.argv[1])\n"
        "except PresetError as e:\n    print(e); sys.exit(1)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code, str(path)],
        cwd=REPO, env=ENV, capture_output=True, text=True, timeout=60, preexec_fn=small_files,
    )  # fmt: skip
    assert result.returncode == 1, result.stderr
    assert result.stdout.strip() == f"{path}: cannot save: File too large"
    assert path.read_bytes() == old
    assert [p.name for p in tmp_path.iterdir()] == ["sand.json"], "no temporary file is left"


def test_stray_temporaries_of_dead_writers_go_and_live_ones_stay(tmp_path):
    sleeper = _python("import time; time.sleep(60)")
    try:
        dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True).stdout.strip()  # fmt: skip
        (tmp_path / f".sand.json.{dead}-0badcafe.tmp").write_text("half")
        (tmp_path / f".sand.json.{sleeper.pid}-00c0ffee.tmp").write_text("being written")
        (tmp_path / ".other.json.1-deadbeef.tmp").write_text("another file's")
        Preset().save(tmp_path / "sand.json")
        names = sorted(p.name for p in tmp_path.iterdir())
        assert names == [
            ".other.json.1-deadbeef.tmp",
            f".sand.json.{sleeper.pid}-00c0ffee.tmp",
            "sand.json",
        ]
        assert remove_stray_temporaries(tmp_path, "sand.json") == 0
    finally:
        sleeper.kill()
        sleeper.wait()


def test_temporaries_named_with_odd_process_ids_never_stop_a_write(tmp_path):
    # "²".isdigit() is true and int("²") raises; no process has an id past the C long.
    odd = (tmp_path / ".sand.json.²-0badcafe.tmp", tmp_path / f".sand.json.{10**30}-0badcafe.tmp")
    for path in odd:
        path.write_text("not ours to judge" if "²" in path.name else "half")
    Preset().save(tmp_path / "sand.json")
    assert sorted(p.name for p in tmp_path.iterdir()) == [odd[0].name, "sand.json"]


def test_a_folder_write_clears_every_files_dead_temporaries_listing_the_folder_once(
    tmp_path, monkeypatch
):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()  # fmt: skip
    names = [f"map{i}.png" for i in range(6)] + ["map0.png.json"]
    for name in names:
        (tmp_path / f".{name}.{dead}-0badcafe.tmp").write_text("half")
    listed = []
    real_listdir = os.listdir
    monkeypatch.setattr(os, "listdir", lambda path: listed.append(path) or real_listdir(path))
    write_folder(tmp_path, {name: name.encode() for name in names})
    assert len(listed) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)


SAVER = """
import sys
from sand_editor.preset import Preset
path = sys.argv[1]
presets = [Preset(name=f"save {i}", description="d" * 2000) for i in range(4)]
print("ready", flush=True)
i = 0
while True:
    presets[i % 4].save(path)
    i += 1
"""


@pytest.mark.slow
def test_200_kills_during_saves_leave_a_whole_file_and_no_stray_temporaries(tmp_path):
    path = tmp_path / "sand.json"
    rng = random.Random(7)
    for _ in range(200):
        saver = subprocess.Popen(
            [sys.executable, "-c", SAVER, str(path)],
            cwd=REPO, env=ENV, stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        assert saver.stdout.readline().strip() == "ready"
        time.sleep(rng.uniform(0.0, 0.03))
        saver.send_signal(signal.SIGKILL)
        saver.wait()
        saver.stdout.close()
        if path.exists():
            assert Preset.load(path).name.startswith("save "), "every saved file is whole"
    Preset(name="after").save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["sand.json"]
    assert Preset.load(path).name == "after"


WRITER = """
import sys, time
from sand_editor.files import write_folder
folder, tag, start = sys.argv[1], sys.argv[2], float(sys.argv[3])
files = {f"{name}.png": (tag * 200_000).encode() for name in "abcdef"}
files["material.json"] = tag.encode()
while time.time() < start:
    pass
write_folder(folder, files)
"""


@pytest.mark.slow
def test_concurrent_writers_into_one_folder_never_mix_their_files(tmp_path):
    mixed = 0
    for round_ in range(20):
        folder = tmp_path / f"round-{round_}"
        start = time.time() + 0.4
        writers = [
            subprocess.Popen(
                [sys.executable, "-c", WRITER, str(folder), tag, str(start)], cwd=REPO, env=ENV
            )  # fmt: skip
            for tag in "WXYZ"
        ]
        assert [w.wait(timeout=60) for w in writers] == [0, 0, 0, 0]
        tags = {path.read_bytes()[:1] for path in folder.iterdir()}
        assert all(not p.name.startswith(".") for p in folder.iterdir()), "no temporary left"
        mixed += len(tags) > 1
    assert mixed == 0


def test_write_folder_replaces_nothing_when_one_file_cannot_be_written(tmp_path):
    write_folder(tmp_path, {"a.png": b"old a", "b.png": b"old b"})
    (tmp_path / "c.png").mkdir()
    with pytest.raises(OutputError, match=r"c\.png: is a folder"):
        write_folder(tmp_path, {"a.png": b"new a", "b.png": b"new b", "c.png": b"new c"})
    assert (tmp_path / "a.png").read_bytes() == b"old a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.png", "c.png"]


def test_preset_save_over_a_device_is_a_preset_error(tmp_path):
    fifo = tmp_path / "sand.json"
    os.mkfifo(fifo)
    with pytest.raises(PresetError, match="sand.json: is a FIFO"):
        Preset().save(fifo)


@given(st.text(max_size=300))
@example("../x")
@example("/tmp/x")
@example("..")
@example(".hidden")
@example("a\nb\x1b[2J\u202e\x00")
@example("con.txt")
@example("LPT9")
@example("é" * 200)
@example(" . ")
def test_a_file_stem_names_one_plain_file_whatever_the_text(text):
    stem = file_stem(text)
    assert stem and stem == stem.strip(" .")
    assert not set(stem) & set('/\\<>:"|?*'), stem
    assert ".." not in stem and not stem.startswith(".")
    assert all(char.isprintable() for char in stem), repr(stem)
    assert len(stem.encode("utf-8")) <= MAX_STEM_BYTES
    assert stem.split(".")[0].upper() not in {"CON", "PRN", "AUX", "NUL", "COM1", "LPT9"}
    assert file_stem(stem) == stem, "a safe stem is kept as it is"


def test_a_file_stem_keeps_a_plain_name_and_readable_unicode():
    assert file_stem("red-desert") == "red-desert"
    assert file_stem("Sable d'Érg Chebbi 2") == "Sable d'Érg Chebbi 2"
    assert file_stem("../../ESCAPED_rel") == "_._ESCAPED_rel"
    assert file_stem("/tmp/ESCAPED_abs") == "_tmp_ESCAPED_abs"
    assert file_stem("...") == "sand"


@pytest.mark.parametrize("name", ["../a.png", "/tmp/a.png", "sub/a.png", "..", ".", "", "a\0b"])
def test_write_folder_refuses_a_name_outside_the_folder_and_writes_nothing(tmp_path, name):
    out = tmp_path / "deep" / "out"
    with pytest.raises(OutputError, match="allowed a file name inside this folder") as raised:
        write_folder(out, {"ok.png": b"fine", name: b"escaped"})
    assert "\n" not in str(raised.value)
    assert list(tmp_path.iterdir()) == [], "nothing made, not even the folder"
