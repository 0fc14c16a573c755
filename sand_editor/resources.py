"""Where the shipped shaders, presets and UI files live.

In an installed wheel they sit inside the package (``sand_editor/shaders`` …); in a checkout they
are the top-level folders of the repository. Both layouts resolve here, nowhere else.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def _folder(name: str) -> Path:
    packaged = _PACKAGE_DIR / name
    if packaged.is_dir():
        return packaged
    checkout = _PACKAGE_DIR.parent / name
    if checkout.is_dir():
        return checkout
    raise FileNotFoundError(
        f"sand_editor resources: no {name!r} folder in {_PACKAGE_DIR} or beside it"
    )


def shaders_dir() -> Path:
    return _folder("shaders")


def presets_dir() -> Path:
    return _folder("presets")


def ui_dir() -> Path:
    return _folder("ui")


def bundled_preset(name: str) -> Path:
    """Path of a preset shipped with the editor, by name (``"paper-default"``)."""
    path = presets_dir() / f"{name}.json"
    if not path.is_file():
        known = ", ".join(sorted(p.stem for p in presets_dir().glob("*.json")))
        raise FileNotFoundError(f"no bundled preset {name!r}; bundled presets: {known}")
    return path


BENCH_SHADERS = "bench/"  # names under it are the benchmark's own, kept out of the product


def bench_shaders_dir() -> Path:
    """The benchmark's own shaders (named ``bench/…``): inside the package in both layouts."""
    return _PACKAGE_DIR / "bench" / "shaders"


@cache
def shader_source(name: str) -> str:
    """Text of a GLSL file in ``shaders/`` (or, named ``bench/…``, of the benchmark's own
    shaders in ``sand_editor/bench/shaders/``), read once and cached."""
    if name.startswith(BENCH_SHADERS):
        path = bench_shaders_dir() / name[len(BENCH_SHADERS) :]
    else:
        path = shaders_dir() / name
    return path.read_text(encoding="utf-8")
