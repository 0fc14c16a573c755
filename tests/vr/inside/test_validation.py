"""The OpenXR core validation layer is in the chain, once and Debian's, its log gets what it
reports, and conftest.py's check of each test does fail a test that provokes a problem."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import xr

from sand_editor.vr.xr_backend import create_instance

pytestmark = pytest.mark.openxr

LAYER = "XR_APILAYER_LUNARG_core_validation"
DEBIAN_LAYER_SO = "/usr/lib/x86_64-linux-gnu/openxr/1/api_layers/libXrApiLayer_core_validation.so"
WRONG_TYPE_VUIDS = ("VUID-XrSystemGetInfo-type-type", "VUID-xrGetSystem-getInfo-parameter")
# The same provocation for the inner suite below, which has no sand_editor on its path.
_PROVOKE = """
import xr

def provoke():
    instance = xr.create_instance(xr.InstanceCreateInfo())
    try:
        info = xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY)
        info.type = xr.StructureType.SESSION_CREATE_INFO
        try:
            xr.get_system(instance, info)
        except xr.ValidationFailureError:
            pass
    finally:
        xr.destroy_instance(instance)
"""


def _needs_validation(log) -> None:
    if not log.enabled:
        pytest.skip("the core validation layer is off (tools/monado/run --no-validation)")


def _loaded_core_validation_libraries() -> list[str]:
    with open("/proc/self/maps") as f:
        paths = {line.split()[-1] for line in f if "libXrApiLayer_core_validation" in line}
    return sorted(paths)


def test_the_layer_is_loaded_once_and_it_is_debians(xr_validation):
    _needs_validation(xr_validation)
    assert os.environ.get("XR_ENABLE_API_LAYERS") == LAYER
    names = [p.layer_name for p in xr.enumerate_api_layer_properties()]
    names = [n.decode() if isinstance(n, bytes) else n for n in names]
    # pyopenxr bundles a copy; the harness hides its manifest so that only one is offered.
    assert names.count(LAYER) == 1, names
    instance = create_instance()
    try:
        assert _loaded_core_validation_libraries() == [DEBIAN_LAYER_SO]
    finally:
        xr.destroy_instance(instance)
    vuids = [r.vuid for r in xr_validation.records()]
    assert "VUID-CoreValidation-Initialize" in vuids, vuids
    assert "VUID-CoreValidation-Destroy" in vuids, vuids


@pytest.mark.xr_validation_expected(*(re.escape(f"VALID_ERROR | {v} |") for v in WRONG_TYPE_VUIDS))
def test_a_wrong_structure_type_is_logged_as_a_validation_error(xr_validation):
    _needs_validation(xr_validation)
    instance = create_instance()
    try:
        info = xr.SystemGetInfo(form_factor=xr.FormFactor.HEAD_MOUNTED_DISPLAY)
        info.type = xr.StructureType.SESSION_CREATE_INFO
        # The layer stops the call (XR_ERROR_VALIDATION_FAILURE) before it reaches Monado.
        with pytest.raises(xr.ValidationFailureError):
            xr.get_system(instance, info)
        # Each record is flushed as it is written.
        errors = [r for r in xr_validation.problems() if r.severity == "VALID_ERROR"]
        assert [r.vuid for r in errors] == list(WRONG_TYPE_VUIDS), errors
        assert {r.function for r in errors} == {"xrGetSystem"}
        assert "invalid XrStructureType" in errors[0].message
    finally:
        xr.destroy_instance(instance)


def test_an_unexpected_validation_error_fails_the_test(xr_validation, tmp_path):
    """conftest.py's check, run on a small suite of its own with a log of its own."""
    _needs_validation(xr_validation)
    shutil.copy(Path(__file__).with_name("conftest.py"), tmp_path / "conftest.py")
    (tmp_path / "provoke.py").write_text(_PROVOKE)
    (tmp_path / "test_inner.py").write_text(
        textwrap.dedent(
            """
            import pytest
            import xr
            from provoke import provoke

            def test_clean():
                xr.destroy_instance(xr.create_instance(xr.InstanceCreateInfo()))

            def test_unmarked_provocation():
                provoke()

            @pytest.mark.xr_validation_expected(r"VUID-XrSystemGetInfo-type-type", r"getInfo")
            def test_marked_provocation():
                provoke()

            @pytest.mark.xr_validation_expected(r"VUID-something-else")
            def test_marked_but_not_what_was_logged():
                provoke()

            @pytest.mark.xr_validation_expected(r"VUID-XrSystemGetInfo-type-type")
            def test_marked_but_not_provoked():
                pass
            """
        )
    )
    log = tmp_path / "inner-validation.log"
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_ADDOPTS"}
    env.update(XR_CORE_VALIDATION_FILE_NAME=str(log), SAND_EDITOR_XR_VALIDATION_LOG=str(log))
    env["PYTHONPATH"] = str(tmp_path)
    inner = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-rE", "-p", "no:cacheprovider", "--strict-markers"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    output = inner.stdout + inner.stderr
    assert inner.returncode == 1, output
    errored = set(re.findall(r"ERROR at teardown of (\w+)", output))
    assert errored == {
        "test_unmarked_provocation",
        "test_marked_but_not_what_was_logged",
        "test_marked_but_not_provoked",
    }, output
    assert "VALID_ERROR | VUID-XrSystemGetInfo-type-type | xrGetSystem" in output
    assert "VUID-XrSystemGetInfo-type-type" in log.read_text()
    # The outer log is untouched: this test itself logs nothing.
    assert xr_validation.problems() == []
