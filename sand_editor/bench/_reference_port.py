"""The reference's texture generator, ported to GLSL at its original cost, and a float64 oracle.

The port is the "before" side of the speed-against-error benchmark: float32 sine hashes, nine
27-cell Worley searches per layer per pixel, an unused edge-distance pass, no early exit over
layers, and finite-difference normals. The oracle evaluates the same function in float64 with the
exact gradient, so what separates the two is the reference's numerical weakness, nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import moderngl
import numpy as np

from sand_editor.gl import draw_fullscreen, drawing_into, fullscreen_program, release_program

_RGB = tuple[float, float, float]

_HASH3_K = np.array(
    [[127.1, 311.7, 74.7], [269.5, 183.3, 246.1], [113.5, 271.9, 124.6]], dtype=np.float64
)
_HASH1_K = np.array([12.9898, 78.233, 37.719], dtype=np.float64)
_HASH_SCALE = 143758.5453
# The same visiting order as the shader's nested loops (x outer, z inner), so that ties between
# equal distances resolve to the same cell.
_OFFSETS = np.array(
    [(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)], dtype=np.float64
)
_ORACLE_CHUNK = 1 << 15


@dataclass(frozen=True)
class ReferenceParams:
    """Generation parameters in the reference's own units; defaults are its saved material."""

    layers: int = 10
    threshold: float = 0.296
    roundness: float = 0.28
    seed: float = 0.27
    jitter: float = 1.44
    period: float = 36.0
    fd_step: float = 1e-4
    layer_darkness: float = 0.085
    base_color: _RGB = (1.0, 0.845, 0.769)
    colors: tuple[_RGB, _RGB, _RGB, _RGB] = (
        (1.0, 0.843, 0.769),
        (0.396, 0.164, 0.054),
        (1.0, 0.769, 0.655),
        (1.0, 0.843, 0.769),
    )
    weights: tuple[float, float, float, float] = (22.0, 18.0, 56.0, 4.0)

    @classmethod
    def from_preset(cls, preset: Any, **overrides: Any) -> ReferenceParams:
        """The reference parameters that a preset's generation section stands for.

        The preset's integer seed becomes the reference's continuous slice position, and its
        jitter in [0, 1] the reference's hidden range [0.44, 1.44]. The finite-difference step
        is not a preset field; it keeps the reference's value unless overridden.
        """
        g = preset.generation
        values: dict[str, Any] = dict(
            layers=int(g.layers),
            threshold=float(g.threshold),
            roundness=float(g.roundness),
            seed=(int(g.seed) % 1000) / 1000.0,
            jitter=0.44 + float(g.jitter),
            period=float(g.period),
            layer_darkness=float(g.layer_darkness),
            base_color=tuple(float(c) for c in g.base_color.srgb),
            colors=tuple(tuple(float(c) for c in color.srgb) for color in g.colors),
            weights=tuple(float(w) for w in g.weights),
        )
        values.update(overrides)
        return cls(**values)


class ReferencePort:
    """Renders the reference's textures on a moderngl context into float32 render targets."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        self._program = fullscreen_program(ctx, "bench/reference_port.frag")
        self._targets: dict[int, tuple[moderngl.Framebuffer, list[moderngl.Texture]]] = {}
        self._size: int | None = None

    def _framebuffer(self, size: int) -> moderngl.Framebuffer:
        if size not in self._targets:
            textures = [
                self._ctx.texture((size, size), 4, dtype="f4"),
                self._ctx.texture((size, size), 4, dtype="f4"),
                self._ctx.texture((size, size), 1, dtype="f4"),
            ]
            fbo = self._ctx.framebuffer(color_attachments=textures)
            self._targets[size] = (fbo, textures)
        return self._targets[size][0]

    def _set(self, name: str, value: Any) -> None:
        if name in self._program:
            self._program[name].value = value

    def render(self, params: ReferenceParams, size: int) -> None:
        """Draw the textures at ``size``×``size``; nothing is read back (see :meth:`read`)."""
        if size < 1:
            raise ValueError(f"size must be positive, got {size}")
        fbo = self._framebuffer(size)
        self._set("u_size", float(size))
        self._set("u_layers", int(params.layers))
        self._set("u_threshold", float(params.threshold))
        self._set("u_roundness", float(params.roundness))
        self._set("u_seed", float(params.seed))
        self._set("u_jitter", float(params.jitter))
        self._set("u_period", float(params.period))
        self._set("u_fd_step", float(params.fd_step))
        self._set("u_layer_darkness", float(params.layer_darkness))
        self._set("u_base_color", tuple(params.base_color))
        self._set("u_colors", [tuple(c) for c in params.colors])
        self._set("u_weights", tuple(params.weights))
        self._set("u_keep", 0.0)
        with drawing_into(self._ctx, fbo):
            self._ctx.viewport = (0, 0, size, size)
            draw_fullscreen(self._ctx, self._program)
        self._size = size

    def read(self) -> dict[str, np.ndarray]:
        """The last render's textures; rows are v (texture y), columns u."""
        if self._size is None:
            raise RuntimeError("ReferencePort.read() before render()")
        size = self._size
        _, (normal_height, albedo_glint, layer) = self._targets[size]
        nh = np.frombuffer(normal_height.read(), dtype=np.float32).reshape(size, size, 4)
        ag = np.frombuffer(albedo_glint.read(), dtype=np.float32).reshape(size, size, 4)
        ly = np.frombuffer(layer.read(), dtype=np.float32).reshape(size, size)
        return {
            "normal": nh[..., :3].copy(),
            "height": nh[..., 3].copy(),
            "albedo": ag[..., :3].copy(),
            "glint": ag[..., 3].copy(),
            "layer": np.rint(ly).astype(np.int8),
        }

    def release(self) -> None:
        for fbo, textures in self._targets.values():
            fbo.release()
            for texture in textures:
                texture.release()
        self._targets.clear()
        release_program(self._program)


def _fract(x: np.ndarray) -> np.ndarray:
    return x - np.floor(x)


def _sine_hash(cm: np.ndarray, k: np.ndarray, precision: str) -> np.ndarray:
    """fract(sin(dot(cm, k)) * 143758.5453) for the rows of ``k``, in the given precision.

    In float32 the dot product is summed as x + (y + z), the order Mesa's llvmpipe uses, so that
    the hash matches that backend's for nearly all cells; the sine's last bits may still differ.
    """
    if precision == "float64":
        return _fract(np.sin(cm @ k.T) * _HASH_SCALE)
    c32 = cm.astype(np.float32)[..., None, :]
    terms = c32 * k.astype(np.float32)
    q = terms[..., 0] + (terms[..., 1] + terms[..., 2])
    return _fract(np.sin(q) * np.float32(_HASH_SCALE)).astype(np.float64)


def _worley64(p: np.ndarray, period: float, jitter: float, precision: str):
    """F1, F2 (unclamped), the closest and second-closest feature points and the grain scalar."""
    n = p.shape[0]
    c = np.floor(p)[:, None, :] + _OFFSETS[None, :, :]
    cm = c - period * np.floor(c / period)
    features = c + jitter * _sine_hash(cm, _HASH3_K, precision)
    d = p[:, None, :] - features
    f = np.einsum("nkj,nkj->nk", d, d)
    # A stable sort keeps the first-visited cell among equal distances, as the shader's strict
    # comparisons do.
    order = np.argsort(f, axis=1, kind="stable")[:, :2]
    rows = np.arange(n)
    i1, i2 = order[:, 0], order[:, 1]
    r = _sine_hash(cm[rows, i1], _HASH1_K[None, :], precision)[:, 0]
    return f[rows, i1], f[rows, i2], features[rows, i1], features[rows, i2], r


def _sqrt_grad(p: np.ndarray, feature: np.ndarray, f: np.ndarray) -> np.ndarray:
    """d sqrt(0.64 F)/dp, zero where the clamp at 1 flattens it and where F is 0."""
    live = (f > 0.0) & (f < 1.0)
    safe = np.where(live, np.sqrt(np.where(live, f, 1.0)), 1.0)
    return np.where(live[:, None], 0.8 * (p - feature) / safe[:, None], 0.0)


def port_oracle(
    params: ReferenceParams,
    size: int,
    xs: np.ndarray,
    ys: np.ndarray,
    *,
    hash_precision: str = "float64",
) -> dict[str, np.ndarray]:
    """The port's function in float64 at pixel centres (xs, ys), with the exact gradient.

    Returns ``"normal"`` (n, 3), ``"layer"`` (n,) int8 (-1 where no layer owns the pixel) and
    ``"height"`` (n,). Evaluated in chunks, so any number of pixels fits in memory.

    ``hash_precision="float64"`` is the function as written. The sine hash amplifies the last bits
    of its argument by about 1e5, so a float32 GPU and float64 disagree on nearly every feature
    point and the two textures are unrelated sand (the reference's hardware dependence).
    ``"float32"`` evaluates only the hash as a float32 GPU does and everything else in float64,
    which leaves the finite-difference error alone to measure.
    """
    if hash_precision not in ("float64", "float32"):
        raise ValueError(f"hash_precision must be 'float64' or 'float32', got {hash_precision!r}")
    xs = np.asarray(xs).ravel()
    ys = np.asarray(ys).ravel()
    if xs.shape != ys.shape:
        raise ValueError("xs and ys must have the same number of pixels")
    normal = np.zeros((xs.size, 3))
    normal[:, 2] = 1.0
    layer = np.full(xs.size, -1, dtype=np.int8)
    height = np.zeros(xs.size)
    for start in range(0, xs.size, _ORACLE_CHUNK):
        part = slice(start, start + _ORACLE_CHUNK)
        n_, l_, h_ = _oracle_chunk(params, size, xs[part], ys[part], hash_precision)
        normal[part], layer[part], height[part] = n_, l_, h_
    return {"normal": normal, "layer": layer, "height": height}


def _oracle_chunk(
    params: ReferenceParams, size: int, xs: np.ndarray, ys: np.ndarray, precision: str
):
    period = float(params.period)
    u = (xs.astype(np.float64) + 0.5) / size
    v = (ys.astype(np.float64) + 0.5) / size
    base = np.stack([u * period, np.full_like(u, params.seed * period), v * period], axis=1)
    normal = np.zeros((xs.size, 3))
    normal[:, 2] = 1.0
    layer = np.full(xs.size, -1, dtype=np.int8)
    height = np.zeros(xs.size)
    for i in range(int(params.layers)):
        open_ = layer < 0
        if not open_.any():
            break
        p = base[open_] + 100.0 * i
        f1, f2, feat1, feat2, _ = _worley64(p, period, params.jitter, precision)
        f1c, f2c = np.clip(f1, 0.0, 1.0), np.clip(f2, 0.0, 1.0)
        prof = 0.1 + np.sqrt(0.64 * f2c) - np.sqrt(0.64 * f1c)
        round_enough = 1.0 - (0.1 + np.sqrt(params.roundness * 10.0 * f1c)) > 0.0
        owns = (prof > params.threshold) & round_enough
        grad = _sqrt_grad(p, feat2, f2) - _sqrt_grad(p, feat1, f1)
        nrm = np.stack([-grad[:, 0], -grad[:, 2], prof], axis=1)
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        idx = np.flatnonzero(open_)[owns]
        normal[idx] = nrm[owns]
        layer[idx] = i
        height[idx] = prof[owns]
    return normal, layer, height
