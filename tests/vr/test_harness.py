"""Host-side tests of tools/monado/run, and the entry point of the inside VR suite."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

pytestmark = [pytest.mark.openxr, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
CACHE = Path(os.environ.get("SAND_EDITOR_CACHE", Path.home() / ".cache" / "sand-editor"))
MONADO_ROOT = CACHE / "monado-root"

SUITE_TIMEOUT = 600

VALIDATION_LAYER = "XR_APILAYER_LUNARG_core_validation"
DEBIAN_LAYER_SO = "/usr/lib/x86_64-linux-gnu/openxr/1/api_layers/libXrApiLayer_core_validation.so"
DEFAULT_VALIDATION_LOG = "/tmp/xr-validation.log"
VALIDATION_STATUS = 119
SUMMARY = re.compile(r"^monado: validation: (\d+) VALID_ERROR, (\d+) VALID_WARNING", re.M)
# Creates an instance; prints the layer settings it saw and the core validation libraries loaded.
XR_PROBE = """
import os, xr
for name in ("XR_ENABLE_API_LAYERS", "XR_CORE_VALIDATION_FILE_NAME",
             "SAND_EDITOR_XR_VALIDATION_LOG"):
    print(name, os.environ.get(name, "unset"))
instance = xr.create_instance(xr.InstanceCreateInfo())
with open("/proc/self/maps") as f:
    for so in sorted({l.split()[-1] for l in f if "libXrApiLayer_core_validation" in l}):
        print("LOADED", so)
xr.destroy_instance(instance)
"""
# Calls xrGetSystem with a wrong structure type, which the layer reports as two VALID_ERRORs
# and stops (XR_ERROR_VALIDATION_FAILURE); exits with the status in argv[1].
XR_PROVOKE = """
import sys, xr
instance = xr.create_instance(xr.InstanceCreateInfo())
info = xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY)
info.type = xr.StructureType.SESSION_CREATE_INFO
try:
    xr.get_system(instance, info)
except xr.ValidationFailureError:
    print("PROVOKED")
xr.destroy_instance(instance)
sys.exit(int(sys.argv[1]))
"""
PROVOKED_VUIDS = {"VUID-XrSystemGetInfo-type-type", "VUID-xrGetSystem-getInfo-parameter"}


def run_dir_of(stderr: str) -> Path | None:
    match = re.search(r"^monado: run directory (\S+)$", stderr, re.M)
    return Path(match.group(1)) if match else None


def _run(
    harness: Path, *args: str, timeout: float = 120, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(harness), *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=None if env is None else {**os.environ, **env},
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


def _assert_no_leftovers(deadline_s: float = 10) -> None:
    # The run's last processes die by SIGKILL as its PID namespace ends, and the kernel tears
    # a namespace down asynchronously: on a loaded machine they can outlive the harness by a
    # moment. A leak is what is still there seconds later.
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
    # The command would sleep 120 s; _run gives up (an error) at 60, so a return at all means
    # the harness stopped it, and 124 with its message says it was the harness's own timeout.
    result = _run(monado_harness, "--timeout", "3", "sh", "-c", "sleep 120", timeout=60)
    _remove_run_dir(result.stderr)
    assert result.returncode == 124, result.stderr
    assert "timed out after 3 s" in result.stderr
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


def _probe_lines(stdout: str) -> dict[str, str]:
    lines = stdout.splitlines()
    return dict(line.split(" ", 1) for line in lines if line.startswith(("XR_", "SAND_")))


def _loaded(stdout: str) -> list[str]:
    return [line.split(" ", 1)[1] for line in stdout.splitlines() if line.startswith("LOADED ")]


def _validation_summary(stderr: str) -> tuple[int, int] | None:
    found = SUMMARY.findall(stderr)
    assert len(found) <= 1, stderr
    return (int(found[0][0]), int(found[0][1])) if found else None


def _reported_vuids(stderr: str) -> set[str]:
    return set(re.findall(r"^monado:   \[[^]]*\]\[VALID_\w+ \| (\S+) \|", stderr, re.M))


def test_validation_layer_is_on_by_default(monado_harness):
    result = _run(monado_harness, "python", "-c", XR_PROBE)
    _remove_run_dir(result.stderr)
    assert result.returncode == 0, result.stderr
    assert _probe_lines(result.stdout) == {
        "XR_ENABLE_API_LAYERS": VALIDATION_LAYER,
        "XR_CORE_VALIDATION_FILE_NAME": DEFAULT_VALIDATION_LOG,
        "SAND_EDITOR_XR_VALIDATION_LOG": DEFAULT_VALIDATION_LOG,
    }, result.stdout
    # Debian's layer, once: not pyopenxr's bundled copy, nor both.
    assert _loaded(result.stdout) == [DEBIAN_LAYER_SO], result.stdout
    assert _validation_summary(result.stderr) == (0, 0), result.stderr
    assert "loaded by 1 OpenXR instance(s)" in result.stderr


def test_no_validation_turns_the_layer_off(monado_harness):
    result = _run(monado_harness, "--no-validation", "python", "-c", XR_PROBE)
    _remove_run_dir(result.stderr)
    assert result.returncode == 0, result.stderr
    assert set(_probe_lines(result.stdout).values()) == {"unset"}, result.stdout
    assert _loaded(result.stdout) == [], result.stdout
    assert "monado: validation" not in result.stderr
    both = _run(monado_harness, "--no-validation", "--fail-on-validation", "true")
    assert both.returncode == 125, both.stderr


def test_fail_on_validation(monado_harness):
    provoked = _run(monado_harness, "--fail-on-validation", "python", "-c", XR_PROVOKE, "0")
    _remove_run_dir(provoked.stderr)
    assert provoked.returncode == VALIDATION_STATUS, provoked.stderr
    assert "PROVOKED" in provoked.stdout
    assert _validation_summary(provoked.stderr) == (2, 0), provoked.stderr
    assert _reported_vuids(provoked.stderr) == PROVOKED_VUIDS, provoked.stderr
    assert "monado: --fail-on-validation:" in provoked.stderr
    # Not a harness failure: no runtime logs; the run directory (and the log) is kept.
    assert "--- tail of" not in provoked.stderr
    assert re.search(r"; log /\S+/xr-validation\.log\)$", provoked.stderr, re.M), provoked.stderr

    # The command's own failure comes first.
    failed = _run(monado_harness, "--fail-on-validation", "python", "-c", XR_PROVOKE, "3")
    _remove_run_dir(failed.stderr)
    assert failed.returncode == 3, failed.stderr
    assert _validation_summary(failed.stderr) == (2, 0), failed.stderr

    # Without the option the problems are reported and the command's status stands.
    reported = _run(monado_harness, "python", "-c", XR_PROVOKE, "0")
    _remove_run_dir(reported.stderr)
    assert reported.returncode == 0, reported.stderr
    assert _validation_summary(reported.stderr) == (2, 0), reported.stderr
    assert _reported_vuids(reported.stderr) == PROVOKED_VUIDS, reported.stderr

    clean = _run(monado_harness, "--fail-on-validation", "python", "-c", XR_PROBE)
    _remove_run_dir(clean.stderr)
    assert clean.returncode == 0, clean.stderr
    assert _validation_summary(clean.stderr) == (0, 0), clean.stderr


def test_validation_log_named_by_the_caller(monado_harness):
    scratch = REPO / ".scratch"
    scratch.mkdir(exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="validation-log.", dir=scratch))
    try:
        log = tmp / "sub" / "xr.log"
        log.parent.mkdir()
        earlier = "[2000-01-01 00:00:00][VALID_ERROR | VUID-earlier | xrEarlier] : an earlier run\n"
        log.write_text(earlier)
        env = {"SAND_EDITOR_XR_VALIDATION_LOG": str(log.relative_to(REPO))}
        result = _run(monado_harness, "python", "-c", XR_PROVOKE, "0", env=env)
        _remove_run_dir(result.stderr)
        assert result.returncode == 0, result.stderr
        text = log.read_text()
        assert text.startswith(earlier)
        assert "VUID-XrSystemGetInfo-type-type" in text
        # Only this run's records count.
        assert _validation_summary(result.stderr) == (2, 0), result.stderr
        assert f"; log {log})" in result.stderr

        probe = _run(monado_harness, "python", "-c", XR_PROBE, env=env)
        _remove_run_dir(probe.stderr)
        assert probe.returncode == 0, probe.stderr
        assert _probe_lines(probe.stdout)["SAND_EDITOR_XR_VALIDATION_LOG"] == str(log)
        assert _probe_lines(probe.stdout)["XR_CORE_VALIDATION_FILE_NAME"] == str(log)
        assert _validation_summary(probe.stderr) == (0, 0), probe.stderr

        outside = _run(
            monado_harness, "true", env={"SAND_EDITOR_XR_VALIDATION_LOG": "/var/tmp/xr.log"}
        )
        assert outside.returncode == 125, outside.stderr
        assert "must be inside the checkout" in outside.stderr
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


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
    # The layer was on; what it reported is only what test_validation.py provokes on purpose
    # (each test's own check is tests/vr/inside/conftest.py's).
    errors, warnings = _validation_summary(result.stderr) or (None, None)
    assert errors is not None and errors >= 1 and warnings == 0, result.stderr[-3000:]
    assert _reported_vuids(result.stderr) <= PROVOKED_VUIDS, result.stderr[-3000:]
