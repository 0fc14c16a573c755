"""Fixtures shared by the test suites: the headless GL context and strict numpy."""

from __future__ import annotations

import os

import numpy as np
import pytest


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """GL tests share this thread's headless context, and a Qt test before them may have left a
    window's context current instead (libglvnd allows one kind at a time on a thread): make the
    headless one current again before any fixture of the test uses it."""
    if "gl_ctx" in item.fixturenames:
        from sand_editor.gl import GLUnavailableError, standalone_context

        try:
            standalone_context()
        except GLUnavailableError:
            pass  # the gl_ctx fixture skips, or fails in CI, with the reason


@pytest.fixture(scope="session")
def gl_ctx():
    """The headless EGL context of this thread.

    GL tests skip where no context can be created, except in CI, where that is a failure.
    """
    from sand_editor.gl import GLUnavailableError, standalone_context

    try:
        return standalone_context()
    except GLUnavailableError as exc:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI must run the GL tests: {exc}")
        pytest.skip(str(exc))


@pytest.fixture
def gl_clean(gl_ctx):
    """The context, current (a Qt test may have made its window's current since), with no GL
    error pending before the test and none raised by it."""
    from sand_editor.gl import standalone_context

    assert standalone_context() is gl_ctx
    assert gl_ctx.error == "GL_NO_ERROR", "a GL error was left pending before the test"
    yield gl_ctx
    assert gl_ctx.error == "GL_NO_ERROR"


@pytest.fixture
def strict_numpy():
    """Every floating-point warning (invalid, divide, overflow, underflow) raises."""
    with np.errstate(all="raise"):
        yield
