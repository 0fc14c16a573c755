"""One size policy: every menu, option and check of a tile's size takes it from
``sand_editor.generator.sizes``, and the sets fit one another."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from sand_editor.cli import _parser, export_size
from sand_editor.generator import sizes
from sand_editor.generator.shared import SIZES as SEGMENT_SIZES
from sand_editor.vr.link import SHARED_SIZES

ROOT = Path(__file__).resolve().parents[2]
SETS = ("PREVIEW_SIZES", "VR_SIZES", "SHARED_SIZES", "BAKE_SIZES")


@pytest.mark.parametrize("name", SETS)
def test_each_set_is_powers_of_two_within_the_generators_limits(name):
    values = getattr(sizes, name)
    assert list(values) == sorted(set(values)) and values
    for size in values:
        assert sizes.check_size(size) == size and size & (size - 1) == 0


def test_the_sets_fit_one_another():
    # The editor starts the viewer at its preview's size and shares that tile with it.
    assert set(sizes.PREVIEW_SIZES) <= set(sizes.VR_SIZES) <= set(sizes.SHARED_SIZES)
    assert sizes.DEFAULT_PREVIEW_SIZE in sizes.PREVIEW_SIZES
    assert sizes.DEFAULT_RENDER_SIZE in sizes.VR_SIZES
    assert sizes.DEFAULT_BAKE_SIZE in sizes.BAKE_SIZES
    assert sizes.DEFAULT_EXPORT_SIZE in sizes.BAKE_SIZES
    assert SEGMENT_SIZES == SHARED_SIZES == sizes.SHARED_SIZES


def test_the_command_line_offers_the_policys_sizes():
    parser = _parser()
    vr = parser.parse_args(["vr"])
    assert vr.texture_size == sizes.DEFAULT_RENDER_SIZE
    assert parser.parse_args(["bake", "x", "--out", "o"]).size == sizes.DEFAULT_BAKE_SIZE
    # export's default depends on the format (a glTF's maps, a web page's material)
    assert parser.parse_args(["export", "x", "--out", "o.glb"]).size is None
    assert export_size("glb", None) == export_size(None, None) == sizes.DEFAULT_EXPORT_SIZE
    assert export_size("web", None) == sizes.DEFAULT_RENDER_SIZE
    assert export_size("web", 256) == 256
    assert export_size("godot", None) == sizes.DEFAULT_RENDER_SIZE
    with pytest.raises(SystemExit):
        parser.parse_args(["vr", "--texture-size", str(sizes.VR_SIZES[-1] * 2)])


@pytest.mark.parametrize("bad", [sizes.MIN_SIZE - 1, sizes.MAX_SIZE + 1, 512.0, True, "512"])
def test_sizes_outside_the_policy_are_refused_with_the_range(bad):
    with pytest.raises(ValueError, match=f"{sizes.MIN_SIZE} to {sizes.MAX_SIZE}"):
        sizes.check_size(bad)


def test_numpy_integers_are_sizes():
    assert sizes.check_size(np.int64(256)) == 256 and type(sizes.check_size(np.int64(256))) is int


def test_no_other_module_writes_a_table_of_sizes():
    # Two or more powers of two from 64 up, in a row in a tuple or list: a copied size table.
    table = re.compile(r"[(\[]\s*(?:(?:64|128|256|512|1024|2048|4096)\s*,\s*){2,}")
    found = []
    for path in sorted((ROOT / "sand_editor").rglob("*.py")):
        if path.name == "sizes.py" or "bench" in path.parts:
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if table.search(line) or "64-4096" in line:
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert found == []
