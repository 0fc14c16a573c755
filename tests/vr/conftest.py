"""VR tests: the viewer's parts that run anywhere (maths, actions, link, workbench, desktop
preview under Xvfb), and two halves that need the OpenXR runtime.

``tests/vr/inside/`` runs inside tools/monado/run (a trixie root with Monado's
simulated HMD, Xvfb and a cp313 venv); it imports ``xr`` and needs the runtime,
so it is collected only when SAND_EDITOR_IN_MONADO=1, which the harness sets.
On the host, ``test_harness.py`` drives the harness, including running the
inside suite through it.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

IN_MONADO = os.environ.get("SAND_EDITOR_IN_MONADO") == "1"
REPO = Path(__file__).resolve().parents[2]
RUN = REPO / "tools" / "monado" / "run"
# Generous: a cold cache means debootstrap plus apt (about a minute on a fast mirror).
BUILD_TIMEOUT = 900

collect_ignore = ["test_harness.py"] if IN_MONADO else ["inside"]


def pytest_collection_modifyitems(items):
    # Only what needs the runtime is marked: the viewer's maths, actions, link and desktop
    # preview run anywhere.
    inside = Path(__file__).parent / "inside"
    for item in items:
        path = Path(item.fspath)
        if inside in path.parents or "monado_harness" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.openxr)
            if not IN_MONADO:  # the runtime's own venv has no pytest-xdist
                # One runtime at a time: under pytest-xdist (--dist loadgroup) every test that
                # drives the harness runs on the same worker.
                item.add_marker(pytest.mark.xdist_group("openxr"))


@pytest.fixture(scope="session")
def monado_harness() -> Path:
    """Path of tools/monado/run with its cached root built; skips where it cannot exist."""
    from tests.chroot_harness import built_harness  # host side only

    return built_harness(RUN, "the Monado harness", BUILD_TIMEOUT)
