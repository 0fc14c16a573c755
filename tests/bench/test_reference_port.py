import dataclasses
import types

import numpy as np
import pytest

from sand_editor.bench._reference_port import (
    _HASH1_K,
    ReferenceParams,
    ReferencePort,
    _sine_hash,
    _worley64,
    port_oracle,
)


@pytest.fixture(scope="module")
def port(gl_ctx):
    port = ReferencePort(gl_ctx)
    yield port
    port.release()


def _pixels(size):
    ys, xs = np.mgrid[0:size, 0:size]
    return xs.ravel(), ys.ravel()


def _angles_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


@pytest.mark.gl
def test_port_outputs_are_well_formed(port):
    params = ReferenceParams()
    port.render(params, 64)
    out = port.read()

    assert out["normal"].shape == (64, 64, 3) and out["albedo"].shape == (64, 64, 3)
    assert out["height"].shape == out["glint"].shape == out["layer"].shape == (64, 64)
    assert out["layer"].dtype == np.int8
    for name, value in out.items():
        assert np.isfinite(value).all(), name
    np.testing.assert_allclose(np.linalg.norm(out["normal"], axis=-1), 1.0, atol=1e-5)
    layer = out["layer"]
    assert layer.min() >= -1 and layer.max() <= params.layers - 1
    # The default material leaves gaps and fills pixels from more than one layer.
    assert (layer == -1).any() and len(np.unique(layer[layer >= 0])) > 1
    assert (out["glint"][layer != 0] == 0).all()
    assert ((out["glint"] >= 0) & (out["glint"] < 1)).all()
    assert (out["height"][layer >= 0] > params.threshold).all()
    assert (out["height"][layer < 0] == 0).all()
    np.testing.assert_allclose(
        out["albedo"][layer < 0],
        np.broadcast_to(params.base_color, (np.sum(layer < 0), 3)),
        atol=1e-6,
    )


@pytest.mark.gl
def test_darkening_follows_the_owning_layer(port):
    params = ReferenceParams(colors=((1.0, 1.0, 1.0),) * 4)
    port.render(params, 64)
    out = port.read()
    layer = out["layer"]
    owned = layer >= 0
    expected = np.maximum(0.4, 1.0 - layer[owned] * params.layer_darkness * 0.624)
    np.testing.assert_allclose(out["albedo"][owned], np.repeat(expected[:, None], 3, 1), atol=1e-6)


@pytest.mark.gl
def test_no_layers_gives_the_base_colour_everywhere(port):
    params = ReferenceParams(layers=0)
    port.render(params, 64)
    out = port.read()
    assert (out["layer"] == -1).all()
    np.testing.assert_allclose(out["albedo"], np.broadcast_to(params.base_color, (64, 64, 3)))
    np.testing.assert_array_equal(out["normal"], np.broadcast_to((0.0, 0.0, 1.0), (64, 64, 3)))
    assert (out["glint"] == 0).all() and (out["height"] == 0).all()


@pytest.mark.gl
def test_port_matches_oracle_with_the_gpu_hash(port):
    # The float32 hash isolates the finite-difference error: measured on llvmpipe, 98.9 % of the
    # pixels share their layer, and normals differ by a median 0.43 degrees (0.2 in layer 0,
    # about 1.5 in layer 2, where float32 spacing eats more of the 1e-4 step).
    size = 128
    params = ReferenceParams(layers=3, seed=0.02)
    port.render(params, size)
    out = port.read()
    oracle = port_oracle(params, size, *_pixels(size), hash_precision="float32")

    layer = out["layer"].ravel()
    agree = layer == oracle["layer"]
    assert agree.mean() >= 0.97
    owned = agree & (layer >= 0)
    angles = _angles_deg(out["normal"].reshape(-1, 3)[owned], oracle["normal"][owned])
    assert np.median(angles) < 1.5
    assert np.median(angles[layer[owned] == 0]) < 0.5
    height = out["height"].ravel()[owned]
    assert np.median(np.abs(height - oracle["height"][owned])) < 1e-4


@pytest.mark.gl
def test_float64_hash_gives_unrelated_sand(port):
    # The reference's sine hash magnifies its argument's rounding by about 1e5: the float32 port
    # and the float64 function agree on layer ownership only by chance (measured 36 %).
    size = 128
    params = ReferenceParams(layers=3, seed=0.02)
    port.render(params, size)
    out = port.read()
    oracle = port_oracle(params, size, *_pixels(size))
    assert np.mean(out["layer"].ravel() == oracle["layer"]) < 0.6


def test_oracle_gradient_matches_float64_finite_differences():
    params = ReferenceParams(layers=1)
    size = 64
    xs, ys = _pixels(size)
    oracle = port_oracle(params, size, xs, ys)
    owned = oracle["layer"] == 0
    p = (
        np.stack([(xs + 0.5) / size, np.full(xs.size, params.seed), (ys + 0.5) / size], axis=1)
        * params.period
    )

    def prof(q):
        f1, f2, *_ = _worley64(q, params.period, params.jitter, "float64")
        return 0.1 + np.sqrt(0.64 * np.clip(f2, 0, 1)) - np.sqrt(0.64 * np.clip(f1, 0, 1))

    h = 1e-7
    ex, ez = np.array([h, 0.0, 0.0]), np.array([0.0, 0.0, h])
    gx = (prof(p + ex) - prof(p - ex)) / (2 * h)
    gz = (prof(p + ez) - prof(p - ez)) / (2 * h)
    fd = np.stack([-gx, -gz, prof(p)], axis=1)
    fd /= np.linalg.norm(fd, axis=1, keepdims=True)
    angles = _angles_deg(fd[owned], oracle["normal"][owned])
    # Pixels within h of a Voronoi border see a kink; everywhere else the two are the same.
    assert np.percentile(angles, 99) < 1e-3
    np.testing.assert_allclose(np.linalg.norm(oracle["normal"], axis=1), 1.0, atol=1e-12)


def test_oracle_layers_and_heights():
    params = ReferenceParams(layers=4)
    oracle = port_oracle(params, 32, *_pixels(32))
    layer, height = oracle["layer"], oracle["height"]
    assert layer.dtype == np.int8 and layer.min() >= -1 and layer.max() <= 3
    assert (height[layer >= 0] > params.threshold).all() and (height[layer < 0] == 0).all()
    assert (oracle["normal"][layer < 0] == (0.0, 0.0, 1.0)).all()
    with pytest.raises(ValueError, match="hash_precision"):
        port_oracle(params, 32, *_pixels(32), hash_precision="float16")


def test_float32_hash_follows_float32_arithmetic_and_departs_from_float64():
    rng = np.random.default_rng(7)
    cells = rng.integers(0, 36, size=(200, 3)).astype(np.float64)
    h32 = _sine_hash(cells, _HASH1_K[None, :], "float32")[:, 0]
    h64 = _sine_hash(cells, _HASH1_K[None, :], "float64")[:, 0]
    c, k = cells.astype(np.float32), _HASH1_K.astype(np.float32)
    q = c[:, 0] * k[0] + (c[:, 1] * k[1] + c[:, 2] * k[2])
    s = np.sin(q) * np.float32(143758.5453)
    np.testing.assert_array_equal(h32, (s - np.floor(s)).astype(np.float64))
    gap = np.abs(h32 - h64)
    assert np.median(np.minimum(gap, 1 - gap)) > 0.05


def test_from_preset_maps_the_preset_units():
    try:
        from sand_editor.preset import Preset
    except ImportError:
        Preset = None
    if Preset is not None:
        preset = Preset()
    else:
        color = types.SimpleNamespace(srgb=(1.0, 215 / 255, 196 / 255))
        preset = types.SimpleNamespace(
            generation=types.SimpleNamespace(
                layers=10,
                threshold=0.296,
                roundness=0.28,
                seed=270,
                jitter=1.0,
                period=36,
                layer_darkness=0.085,
                base_color=color,
                colors=(color,) * 4,
                weights=(22, 18, 56, 4),
            )
        )
    g = preset.generation
    params = ReferenceParams.from_preset(preset)
    assert params.layers == g.layers and params.period == float(g.period)
    assert params.seed == pytest.approx((g.seed % 1000) / 1000)
    assert params.jitter == pytest.approx(0.44 + g.jitter)
    assert params.base_color == pytest.approx(g.base_color.srgb)
    assert [c for c in params.colors] == [pytest.approx(c.srgb) for c in g.colors]
    assert params.weights == tuple(float(w) for w in g.weights)
    assert params.fd_step == ReferenceParams().fd_step
    assert ReferenceParams.from_preset(preset, fd_step=1e-3).fd_step == 1e-3
    dataclasses.replace(params)  # stays a plain frozen dataclass
