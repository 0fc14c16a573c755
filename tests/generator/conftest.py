"""Helpers for the generator tests: presets by parameter, cached generation, invariants."""

from __future__ import annotations

import numpy as np
import pytest

from sand_editor.generator import SandTextures, generate
from sand_editor.generator.noise import NoiseConstants
from sand_editor.preset import Preset

# Every floating-point warning raises while generating, so NaN sources surface.
STRICT = {"all": "raise"}


class Sand:
    """Builds presets, generates (cached per preset, size and backend) and checks invariants."""

    def __init__(self) -> None:
        self._cache: dict = {}

    @staticmethod
    def preset(**generation) -> Preset:
        return Preset().replace(**{f"generation.{k}": v for k, v in generation.items()})

    @staticmethod
    def constants(preset: Preset) -> NoiseConstants:
        return NoiseConstants.from_generation(preset.generation)

    def generate(self, preset: Preset, size: int, backend: str) -> SandTextures:
        """Generated textures; the arrays are shared between tests, so never modify them."""
        key = (preset, size, backend)
        if key not in self._cache:
            self._cache[key] = self.generate_fresh(preset, size, backend)
        return self._cache[key]

    @staticmethod
    def generate_fresh(preset: Preset, size: int, backend: str) -> SandTextures:
        with np.errstate(**STRICT):
            return generate(preset, size, backend=backend)

    def check(self, tex: SandTextures, preset: Preset, size: int) -> None:
        """Every documented invariant of SandTextures."""
        nc = self.constants(preset)
        n = size
        fields = {
            "albedo": ((n, n, 3), np.float32),
            "normal": ((n, n, 3), np.float32),
            "height": ((n, n), np.float32),
            "glint": ((n, n), np.float32),
            "layer": ((n, n), np.int8),
            "grain_id": ((n, n), np.uint32),
            "average_albedo": ((3,), np.float32),
        }
        for name, (shape, dtype) in fields.items():
            value = getattr(tex, name)
            assert value.shape == shape, name
            assert value.dtype == dtype, name
            if value.dtype.kind == "f":
                assert np.isfinite(value).all(), f"{name} has NaN or inf"
        assert tex.size == n
        layer = tex.layer
        owned = layer >= 0
        assert layer.min() >= -1 and layer.max() <= max(nc.layers - 1, -1)
        assert 0.0 <= tex.albedo.min() and tex.albedo.max() <= 1.0
        length = np.linalg.norm(tex.normal.astype(np.float64), axis=-1)
        np.testing.assert_allclose(length, 1.0, atol=1e-5)
        assert (tex.normal[..., 2] > 0).all()
        assert (tex.height >= 0).all()
        assert (tex.height[~owned] == 0).all()
        assert (tex.height[owned] > nc.threshold).all()
        gaps = tex.normal[~owned]
        assert (gaps == np.float32([0, 0, 1])).all(), "gaps must have the flat normal"
        assert 0.0 <= tex.glint.min() and tex.glint.max() <= 1.0
        assert (tex.glint[layer != 0] == 0).all()
        assert (tex.albedo[~owned] == nc.base_color.astype(np.float32)).all()
        mean = tex.albedo.mean(axis=(0, 1), dtype=np.float64)
        np.testing.assert_allclose(tex.average_albedo, mean, rtol=1e-6, atol=1e-7)


@pytest.fixture(scope="session")
def sand() -> Sand:
    return Sand()


@pytest.fixture(autouse=True)
def _gl_tests_use_a_clean_context(request):
    """GL tests skip without a context and fail on any GL error they leave."""
    if request.node.get_closest_marker("gl") is not None:
        request.getfixturevalue("gl_ctx")
        request.getfixturevalue("gl_clean")
