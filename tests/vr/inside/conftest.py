"""The OpenXR core validation layer's verdict on every test of the in-runtime suite.

tools/monado/run enables Khronos' core validation layer (``XR_APILAYER_LUNARG_core_validation``,
Debian's ``openxr-layer-corevalidation``) and names its text log in
``SAND_EDITOR_XR_VALIDATION_LOG``. The layer appends one record a line,
``[time][VALID_ERROR | VUID | xrFunction] : message``, flushed at once, from every process of the
run. The autouse fixture ``xr_validation`` notes the log's size before each test and, after the
test and its fixtures' teardown, fails it when the layer logged a VALID_ERROR or VALID_WARNING
meanwhile, unless the test is marked ``xr_validation_expected`` (it provokes them on purpose).
Without the log (``tools/monado/run --no-validation``) it checks nothing.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

LOG_ENV = "SAND_EDITOR_XR_VALIDATION_LOG"
PROBLEMS = ("VALID_ERROR", "VALID_WARNING")
# Continuation lines ("  Objects:", "   [0] - XrInstance (0x...)") do not match; finditer, not
# match per line, in case two processes' records ever share a line.
_RECORD = re.compile(r"\[(VALID_[A-Z_]+) \| (\S+) \| (\S+)\] : (.*)")


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "xr_validation_expected(*patterns): the test provokes OpenXR core validation "
        "messages on purpose. With patterns (regular expressions searched in each "
        "'[SEVERITY | VUID | function] : message'), each must match a VALID_ERROR or "
        "VALID_WARNING logged during the test and every one logged must match one; without, "
        "any are allowed.",
    )


@dataclass(frozen=True)
class Record:
    severity: str
    vuid: str
    function: str
    message: str

    def __str__(self) -> str:
        return f"[{self.severity} | {self.vuid} | {self.function}] : {self.message}"


class ValidationLog:
    """The part of the layer's log written since the test began."""

    def __init__(self, path: Path | None):
        self.path = path
        self.start = self._size()

    @property
    def enabled(self) -> bool:
        return self.path is not None

    def _size(self) -> int:
        try:
            return self.path.stat().st_size if self.path else 0
        except FileNotFoundError:
            return 0

    def records(self) -> list[Record]:
        if self.path is None:
            return []
        try:
            with open(self.path, "rb") as f:
                f.seek(self.start)
                text = f.read().decode("utf-8", "replace")
        except FileNotFoundError:
            return []
        return [Record(*m.groups()) for m in _RECORD.finditer(text)]

    def problems(self) -> list[Record]:
        """The VALID_ERROR and VALID_WARNING records."""
        return [r for r in self.records() if r.severity in PROBLEMS]


def _listing(records) -> str:
    return "\n".join(f"  {r}" for r in records)


@pytest.fixture(autouse=True)
def xr_validation(request) -> ValidationLog:
    path = os.environ.get(LOG_ENV)
    log = ValidationLog(Path(path) if path else None)
    yield log
    if not log.enabled:
        return
    problems = log.problems()
    marker = request.node.get_closest_marker("xr_validation_expected")
    if marker is None:
        if problems:
            pytest.fail(
                f"the OpenXR core validation layer logged {len(problems)} problem(s) during "
                f"the test ({log.path}):\n{_listing(problems)}",
                pytrace=False,
            )
        return
    patterns = [re.compile(p) for p in marker.args]
    if not patterns:
        return
    unexpected = [r for r in problems if not any(p.search(str(r)) for p in patterns)]
    missing = [p.pattern for p in patterns if not any(p.search(str(r)) for r in problems)]
    if unexpected or missing:
        pytest.fail(
            "the OpenXR core validation layer did not log what the test expects "
            f"({log.path}):\nunexpected:\n{_listing(unexpected) or '  none'}\n"
            f"expected but not logged: {missing or 'none'}",
            pytrace=False,
        )
