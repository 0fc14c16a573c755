"""Shapes, dtypes and ranges of the generated textures, hard parameter values, determinism and
argument checking, on both backends."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.generator import BACKENDS, MAX_SIZE, MIN_SIZE, check_size, generate
from sand_editor.generator.noise import MAX_LAYERS, PROFILE_OFFSET

BACKEND_PARAMS = [pytest.param("gl", marks=pytest.mark.gl), "reference"]

# Every generation parameter at its extremes, alone and together.
HARD_CASES = {
    "threshold-0": {"threshold": 0.0},
    "threshold-1": {"threshold": 1.0},
    "roundness-0": {"roundness": 0.0},
    "roundness-1": {"roundness": 1.0},
    "layers-0": {"layers": 0},
    "layers-15": {"layers": MAX_LAYERS},
    "seed-0": {"seed": 0},
    "seed-1": {"seed": 1},
    "seed-max": {"seed": 2**32 - 1},
    "jitter-0": {"jitter": 0.0},
    "jitter-1": {"jitter": 1.0},
    "period-1": {"period": 1},
    "period-256": {"period": 256},
    "all-low": {
        "threshold": 0.0,
        "roundness": 0.0,
        "layers": MAX_LAYERS,
        "seed": 0,
        "jitter": 0.0,
        "period": 1,
        "layer_darkness": 0.0,
        "weights": (0.0, 0.0, 0.0, 100.0),
    },
    "all-high": {
        "threshold": 1.0,
        "roundness": 1.0,
        "layers": MAX_LAYERS,
        "seed": 2**32 - 1,
        "jitter": 1.0,
        "period": 256,
        "layer_darkness": 1.0,
        "weights": (100.0,) * 4,
    },
    "low-threshold-high-rest": {
        "threshold": 0.0,
        "roundness": 1.0,
        "layers": MAX_LAYERS,
        "seed": 2**32 - 1,
        "jitter": 1.0,
        "period": 256,
        "layer_darkness": 1.0,
    },
    "high-threshold-low-rest": {
        "threshold": 1.0,
        "roundness": 0.0,
        "layers": 0,
        "seed": 0,
        "jitter": 0.0,
        "period": 1,
        "layer_darkness": 0.0,
    },
}


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
@pytest.mark.parametrize("size", [128, 100])
def test_default_preset_fields(sand, backend, size, strict_numpy):
    preset = sand.preset()
    tex = sand.generate(preset, size, backend)
    sand.check(tex, preset, size)
    # The default sand has grains on the top layer and some on lower ones.
    assert (tex.layer == 0).mean() > 0.1
    assert (tex.layer > 0).any()
    assert (tex.glint[tex.layer == 0] > 0).mean() > 0.99


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
@pytest.mark.parametrize("size", [64, 96])
@pytest.mark.parametrize("case", list(HARD_CASES))
def test_hard_cases_finite_and_in_range(sand, case, size, backend, strict_numpy):
    preset = sand.preset(**HARD_CASES[case])
    sand.check(sand.generate(preset, size, backend), preset, size)


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
@pytest.mark.parametrize("case", ["threshold-1", "layers-0", "all-high", "high-threshold-low-rest"])
def test_no_grains_gives_flat_base_colour(sand, case, backend, strict_numpy):
    preset = sand.preset(**HARD_CASES[case])
    tex = sand.generate(preset, 64, backend)
    base = sand.constants(preset).base_color.astype(np.float32)
    assert (tex.layer == -1).all()
    assert (tex.albedo == base).all()
    assert (tex.normal == np.float32([0, 0, 1])).all()
    assert (tex.height == 0).all()
    assert (tex.glint == 0).all()
    np.testing.assert_allclose(tex.average_albedo, base, rtol=1e-6)


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
def test_threshold_zero_fills_every_pixel_of_the_top_layer(sand, backend, strict_numpy):
    # The profile is at least PROFILE_OFFSET > 0, and roundness 0 trims nothing.
    tex = sand.generate(sand.preset(threshold=0.0, roundness=0.0), 64, backend)
    assert (tex.layer == 0).all()
    assert (tex.height >= np.float32(PROFILE_OFFSET) - 1e-6).all()


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
def test_roundness_trims_grains(sand, backend, strict_numpy):
    round_, flat = (
        sand.generate(sand.preset(roundness=r, layers=1), 96, backend) for r in (1.0, 0.0)
    )
    owned_round, owned_flat = round_.layer == 0, flat.layer == 0
    assert owned_round.mean() < 0.8 * owned_flat.mean()
    # Trimming only removes pixels: a pixel of a round grain is a pixel of the untrimmed one.
    assert not (owned_round & ~owned_flat).any()
    same = owned_round & owned_flat
    assert (round_.grain_id[same] == flat.grain_id[same]).all()


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
def test_more_layers_fill_more_gaps(sand, backend, strict_numpy):
    gaps = [
        (sand.generate(sand.preset(layers=n), 96, backend).layer == -1).mean()
        for n in (1, 3, MAX_LAYERS)
    ]
    assert gaps[0] > gaps[1] > gaps[2]


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
def test_deeper_layers_are_darker(sand, backend, strict_numpy):
    preset = sand.preset(layer_darkness=0.5, weights=(1.0, 0.0, 0.0, 0.0), threshold=0.5)
    tex = sand.generate(preset, 128, backend)
    lum = tex.albedo.sum(axis=-1)
    means = [lum[tex.layer == k].mean() for k in range(3)]
    assert means[0] > means[1] > means[2]


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
def test_deterministic_bitwise(backend, sand, strict_numpy):
    preset = sand.preset(seed=12345)
    first, second = (sand.generate_fresh(preset, 96, backend) for _ in range(2))
    for name in ("albedo", "normal", "height", "glint", "layer", "grain_id", "average_albedo"):
        a, b = getattr(first, name), getattr(second, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name


@pytest.mark.parametrize("backend", BACKEND_PARAMS)
def test_seed_changes_the_sand(backend, sand, strict_numpy):
    a = sand.generate(sand.preset(seed=1), 64, backend)
    b = sand.generate(sand.preset(seed=2), 64, backend)
    assert (a.layer != b.layer).mean() > 0.2
    assert (a.grain_id != b.grain_id).mean() > 0.5


@pytest.mark.parametrize("size", [MIN_SIZE, 65, 96, 100, 1000, MAX_SIZE, np.int64(256)])
def test_check_size_accepts_any_integer_in_range(size):
    assert check_size(size) == int(size)
    assert type(check_size(size)) is int


@pytest.mark.parametrize("size", [63, 4097, 0, -256, 256.0, True, False, "256", None, 2**70])
@pytest.mark.parametrize("backend", BACKENDS)
def test_bad_size_names_the_range(size, backend):
    with pytest.raises(ValueError, match=f"{MIN_SIZE} to {MAX_SIZE}"):
        generate(None, size, backend=backend)


@pytest.mark.parametrize("backend", ["vulkan", "GL", "", None])
def test_bad_backend_lists_the_allowed(backend, sand):
    with pytest.raises(ValueError, match="gl, reference") as info:
        generate(sand.preset(), 64, backend=backend)
    assert repr(backend) in str(info.value)
