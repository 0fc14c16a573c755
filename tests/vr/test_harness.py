"""Host-side tests of tools/monado/run, and the entry point of the inside VR suite."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

pytestmark = [pytest.mark.openxr, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
CACHE = Path(os.environ.get("SAND_EDITOR_CACHE", Path.home() / ".cache" / "sand-editor"))
MONADO_ROOT = CACHE / "monado-root"

SUITE_TIMEOUT = 600


def run_dir_of(stderr: str) -> Path | None:
    match = re.search(r"^monado: run directory (\S+)$", stderr, re.M)
    return Path(match.group(1)) if match else None


def _run(harness: Path, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(harness), *args], cwd=REPO, capture_output=True, text=True, timeout=timeout
    )


def _mounts_under_root() -> list[str]:
    root = str(MONADO_ROOT.resolve())
    with open("/proc/self/mountinfo") as f:
        return [line for line in f if root in line]


def _processes_in_root() -> list[str]:
    """Processes chrooted into the Monado root: monado-service, Xvfb, the command.

    The root directory is compared by identity (device and inode), not by path: seen from
    inside another chroot, /proc/PID/root of a process in another mount namespace reads as a
    host path.
    """
    try:
        root = os.stat(MONADO_ROOT)
    except OSError:
        return []
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            proc_root = os.stat(entry / "root")
            comm = (entry / "comm").read_text().strip()
        except OSError:
            continue
        if (proc_root.st_dev, proc_root.st_ino) == (root.st_dev, root.st_ino):
            found.append(f"{entry.name} {comm}")
    return found


def _assert_no_leftovers(deadline_s: float = 0) -> None:
    # After a SIGKILL the kernel tears the namespace down asynchronously.
    end = time.monotonic() + deadline_s
    while True:
        mounts, procs = _mounts_under_root(), _processes_in_root()
        if (not mounts and not procs) or time.monotonic() >= end:
            break
        time.sleep(0.2)
    assert not mounts, f"mounts left behind: {mounts}"
    assert not procs, f"processes left behind: {procs}"


def _remove_run_dir(stderr: str) -> None:
    run_dir = run_dir_of(stderr)
    if run_dir is not None:
        shutil.rmtree(run_dir, ignore_errors=True)


def test_exit_status_is_propagated(monado_harness):
    failed = _run(monado_harness, "false")
    _remove_run_dir(failed.stderr)
    assert failed.returncode == 1, failed.stderr
    seven = _run(monado_harness, "sh", "-c", "exit 7")
    _remove_run_dir(seven.stderr)
    assert seven.returncode == 7, seven.stderr


def test_runtime_environment_and_no_leftovers(monado_harness):
    probe = (
        'test -S "$XDG_RUNTIME_DIR/monado_comp_ipc" && test -n "$DISPLAY" '
        '&& test "$SAND_EDITOR_IN_MONADO" = 1 && test "$PWD" = "$SAND_EDITOR_REPO" '
        "&& test -f tools/monado/run && echo inside-ok"
    )
    result = _run(monado_harness, "--keep-tmp", "sh", "-c", probe)
    run_dir = run_dir_of(result.stderr)
    try:
        assert result.returncode == 0, result.stderr
        assert "inside-ok" in result.stdout
        assert re.search(r"^monado: runtime up in [\d.]+ s", result.stderr, re.M)
        assert run_dir is not None and run_dir.is_dir()
        assert (run_dir / "monado.log").is_file()
        sockets = [p for p in run_dir.rglob("*") if p.is_socket()]
        assert not sockets, f"sockets left in the run directory: {sockets}"
        _assert_no_leftovers()
    finally:
        if run_dir is not None:
            shutil.rmtree(run_dir, ignore_errors=True)


def test_timeout_is_honoured_and_cleans_up(monado_harness):
    start = time.monotonic()
    result = _run(monado_harness, "--timeout", "3", "sh", "-c", "sleep 120", timeout=60)
    elapsed = time.monotonic() - start
    _remove_run_dir(result.stderr)
    assert result.returncode == 124, result.stderr
    assert "timed out after 3 s" in result.stderr
    assert elapsed < 30
    _assert_no_leftovers()


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_killed_run_leaves_nothing(monado_harness, sig):
    proc = subprocess.Popen(
        [str(monado_harness), "sh", "-c", "echo started; sleep 120"],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == "started"
        assert _processes_in_root(), "the run should be visible while it is going"
        proc.send_signal(sig)
        _, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    _remove_run_dir(stderr)
    assert proc.returncode != 0
    _assert_no_leftovers(deadline_s=15)


def test_two_runs_at_once(monado_harness):
    script = (
        "import xr; i = xr.create_instance(xr.InstanceCreateInfo()); "
        "print('RUNTIME', xr.get_instance_properties(i).runtime_name.decode()); "
        "xr.destroy_instance(i)"
    )
    procs = [
        subprocess.Popen(
            [str(monado_harness), "--timeout", "120", "python", "-c", script],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for _ in range(2)
    ]
    outputs = [p.communicate(timeout=180) for p in procs]
    for proc, (stdout, stderr) in zip(procs, outputs, strict=True):
        _remove_run_dir(stderr)
        assert proc.returncode == 0, stderr
        assert re.search(r"^RUNTIME Monado", stdout, re.M), stdout
    _assert_no_leftovers()


def _summary_counts(output: str) -> dict[str, int]:
    lines = [line for line in output.splitlines() if re.search(r"\b(passed|failed|error)", line)]
    assert lines, f"no pytest summary line in:\n{output[-3000:]}"
    return {
        word: int(n)
        for n, word in re.findall(
            r"(\d+) (passed|failed|errors?|skipped|x?failed|xpassed)", lines[-1]
        )
    }


def test_vr_suite_in_monado(monado_harness):
    result = _run(
        monado_harness,
        "--timeout",
        str(SUITE_TIMEOUT - 60),
        "python",
        "-m",
        "pytest",
        "tests/vr/inside",
        "-q",
        "-p",
        "no:cacheprovider",
        # The suite needs only tests/vr/conftest.py; conftests further up may
        # import host-only packages (Qt) that the runtime's venv lacks.
        "--confcutdir",
        "tests/vr",
        "-W",
        "ignore::pytest.PytestConfigWarning",
        timeout=SUITE_TIMEOUT,
    )
    _remove_run_dir(result.stderr)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-6000:]
    counts = _summary_counts(result.stdout)
    assert counts.get("passed", 0) >= 1, counts
    assert counts.get("failed", 0) == 0, counts
    assert counts.get("error", 0) + counts.get("errors", 0) == 0, counts
