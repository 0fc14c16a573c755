"""The ``bench`` extra's packages (matplotlib, Mitsuba 3, NVIDIA's FLIP), imported where a
benchmark needs them: a missing one stops the command with one line naming the extra to
install, never a traceback. Benchmarks import them before their run, so that the line comes at
once rather than after minutes of measuring."""

from __future__ import annotations

import importlib
from types import ModuleType

INSTALL_HINT = "pip install 'sand-editor[bench]'"
# The module's top-level name → the distribution in the extra that brings it.
_DISTRIBUTIONS = {
    "matplotlib": "matplotlib",
    "mitsuba": "mitsuba",
    "drjit": "mitsuba",  # Dr.Jit comes with Mitsuba
    "flip_evaluator": "flip-evaluator",
}


class MissingPackage(ImportError):
    """A package of the ``bench`` extra is not installed (or does not load); ``str()`` is one
    line naming it and the extra. The command line reports it as its one-line error."""


def optional_module(name: str, needed_for: str) -> ModuleType:
    """Import ``name``, one of the ``bench`` extra's modules, for ``needed_for`` (what the
    message says needs it: ``"bench relief"``, ``"--plot"``).

    Raises
    ------
    MissingPackage
        What needs which package, why it did not import, and how to install it.
    """
    try:
        return importlib.import_module(name)
    except ImportError as error:
        package = _DISTRIBUTIONS[name.partition(".")[0]]
        raise MissingPackage(
            f"{needed_for} needs the package {package}, which cannot be imported ({error}); "
            f"install the bench extra: {INSTALL_HINT}"
        ) from None


def pyplot(needed_for: str = "--plot") -> ModuleType:
    """``matplotlib.pyplot`` drawing to files only (the Agg backend: no display needed)."""
    matplotlib = optional_module("matplotlib", needed_for)
    matplotlib.use("Agg")
    return optional_module("matplotlib.pyplot", needed_for)
