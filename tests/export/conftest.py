"""Fixtures of the export tests: the Node packages (three.js, the glTF validator)."""

from __future__ import annotations

import os

import pytest

from tests.export.js_tools import js_root


@pytest.fixture(scope="session")
def root():
    """The installed Node packages; skipped without them, except in CI, where that fails."""
    found = js_root()
    if found is None:
        reason = (
            "the Node packages of tools/js are not installed (tools/setup.sh ensure_js_packages)"
        )
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI must run the three.js and validator tests: {reason}")
        pytest.skip(reason)
    return found
