"""The desert: an analytic dune height field y = h(x, z), its exact gradient, and meshes of it.

Dunes are sums of sawtooth-like Fourier series of a phase field that runs along the wind and
bends across it (crescent ridges), over a gentle base undulation. Being analytic, heights and
normals are exact at any coordinate and any mesh resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_SLOPE_DEG = 32.0  # below the ~34° angle of repose of dry sand
# A skewed profile: gentle windward face, steep lee face.
RIDGE_HARMONICS = ((1, 1.0), (2, 0.35), (3, 0.12))


@dataclass(frozen=True)
class _Ridges:
    """One family of ridges: height Σ A·a_n·sin(n·φ) with
    φ = k·(d·p) + m·sin(q·(e·p) + ψ) + φ0, p = (x, z)."""

    amplitude: float
    wavenumber: float
    direction: tuple[float, float]  # along the wind
    bend: float  # phase modulation across the wind: the ridges curve into crescents
    bend_wavenumber: float
    across: tuple[float, float]
    bend_phase: float
    phase: float

    def phase_and_gradient(self, x, z):
        (dx, dz), (ex, ez) = self.direction, self.across
        inner = self.bend_wavenumber * (ex * x + ez * z) + self.bend_phase
        phi = self.wavenumber * (dx * x + dz * z) + self.bend * np.sin(inner) + self.phase
        bend_rate = self.bend * self.bend_wavenumber * np.cos(inner)
        return phi, self.wavenumber * dx + bend_rate * ex, self.wavenumber * dz + bend_rate * ez

    def steepest(self) -> float:
        """An upper bound of |∇h| of this family."""
        phase_rate = self.wavenumber + abs(self.bend) * self.bend_wavenumber
        return self.amplitude * phase_rate * sum(n * abs(a) for n, a in RIDGE_HARMONICS)


class DuneTerrain:
    """Dunes a few metres high over tens of metres, the same for the same ``seed``.

    ``extent_m`` is the radius of desert drawn around the viewer.
    """

    def __init__(self, seed: int = 0, extent_m: float = 2000.0) -> None:
        self.seed = int(seed)
        self.extent_m = float(extent_m)
        rng = np.random.default_rng(self.seed)
        wind = rng.uniform(0, 2 * math.pi)
        families = []
        # (amplitude m, wavelength m, turn from the wind, bend, bend wavelength m)
        for amplitude, wavelength, turn, bend, bend_wavelength in (
            (1.6, 42.0, 0.0, 1.3, 130.0),
            (0.7, 23.0, 0.35, 0.9, 70.0),
            (1.2, 310.0, 1.2, 0.6, 900.0),  # base undulation
        ):
            angle = wind + turn + rng.uniform(-0.15, 0.15)
            direction = (math.cos(angle), math.sin(angle))
            families.append(
                _Ridges(
                    amplitude=amplitude * rng.uniform(0.85, 1.15),
                    wavenumber=2 * math.pi / (wavelength * rng.uniform(0.9, 1.1)),
                    direction=direction,
                    bend=bend,
                    bend_wavenumber=2 * math.pi / bend_wavelength,
                    across=(-direction[1], direction[0]),
                    bend_phase=rng.uniform(0, 2 * math.pi),
                    phase=rng.uniform(0, 2 * math.pi),
                )
            )
        # Scale the dunes down where a seed would make any face steeper than sand can stand.
        limit = math.tan(math.radians(MAX_SLOPE_DEG))
        bound = sum(f.steepest() for f in families)
        scale = min(1.0, limit / bound)
        self._families = tuple(
            _Ridges(**{**f.__dict__, "amplitude": f.amplitude * scale}) for f in families
        )
        self.max_slope_bound = bound * scale  # |∇h| never exceeds this
        # |h| never exceeds this
        self.height_bound = sum(f.amplitude * sum(abs(a) for _, a in RIDGE_HARMONICS)
                                for f in self._families)  # fmt: skip

    def height(self, x, z) -> np.ndarray:
        x, z = _as_float64(x, z)
        h = np.zeros(np.broadcast(x, z).shape)
        for family in self._families:
            phi, _, _ = family.phase_and_gradient(x, z)
            for n, a in RIDGE_HARMONICS:
                h = h + family.amplitude * a * np.sin(n * phi)
        return h

    def clearance(self, eye) -> float:
        """How far a point (world x, y, z) is above the ground below it, in metres."""
        return float(eye[1]) - float(self.height(eye[0], eye[2]))

    def gradient(self, x, z) -> tuple[np.ndarray, np.ndarray]:
        """(∂h/∂x, ∂h/∂z), exact."""
        x, z = _as_float64(x, z)
        shape = np.broadcast(x, z).shape
        gx, gz = np.zeros(shape), np.zeros(shape)
        for family in self._families:
            phi, phi_x, phi_z = family.phase_and_gradient(x, z)
            slope = sum(family.amplitude * a * n * np.cos(n * phi) for n, a in RIDGE_HARMONICS)
            gx, gz = gx + slope * phi_x, gz + slope * phi_z
        return gx, gz

    def surface(self, x, z, origin=None) -> dict[str, np.ndarray]:
        """Vertex attributes at world (x, z): ``position`` (relative to ``origin`` when given,
        which keeps millimetre detail far from the world origin), ``normal``, ``tangent`` (unit,
        along +x on the surface) and ``uv`` = world (x, z); all float32."""
        x, z = _as_float64(x, z)
        x, z = np.broadcast_arrays(x, z)
        h = self.height(x, z)
        gx, gz = self.gradient(x, z)
        position = np.stack([x, h, z], axis=-1)
        if origin is not None:
            position = position - np.asarray(origin, dtype=np.float64)
        normal = np.stack([-gx, np.ones_like(gx), -gz], axis=-1)
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        # d(position)/dx = (1, ∂h/∂x, 0) lies in the surface, so it is orthogonal to the normal.
        tangent = np.stack([np.ones_like(gx), gx, np.zeros_like(gx)], axis=-1)
        tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
        return {
            "position": position.reshape(-1, 3).astype(np.float32),
            "normal": normal.reshape(-1, 3).astype(np.float32),
            "tangent": tangent.reshape(-1, 3).astype(np.float32),
            "uv": np.stack([x, z], axis=-1).reshape(-1, 2).astype(np.float32),
        }

    def mesh(self, center_xz, extent_m: float, resolution: int, origin=None) -> dict:
        """A square grid of ``resolution``² vertices, ``extent_m`` wide, centred on
        ``center_xz``."""
        if resolution < 2:
            raise ValueError(f"resolution must be at least 2, got {resolution}")
        offsets = np.linspace(-extent_m / 2, extent_m / 2, resolution)
        z, x = np.meshgrid(center_xz[1] + offsets, center_xz[0] + offsets, indexing="ij")
        mesh = self.surface(x, z, origin)
        mesh["index"] = _grid_index(resolution, resolution)
        mesh["ripples"] = True
        return mesh

    def radial_mesh(
        self, center_xz, inner_m: float, outer_m: float, segments: int = 96, origin=None
    ) -> dict:
        """Rings around ``center_xz`` whose spacing grows with the distance from it, from
        ``inner_m`` to ``outer_m``: every cell spans about the same angle seen from above the
        centre, so a viewer there sees the same detail from a millimetre to the horizon."""
        growth = 1.0 + 2 * math.pi / segments  # square-ish cells
        rings = max(2, math.ceil(math.log(outer_m / inner_m) / math.log(growth)) + 1)
        radii = np.concatenate([[0.0], inner_m * growth ** np.arange(rings)])
        radii[-1] = max(radii[-1], outer_m)
        angles = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
        x = center_xz[0] + radii[:, None] * np.cos(angles)[None, :]
        z = center_xz[1] + radii[:, None] * np.sin(angles)[None, :]
        # The centre ring has radius 0: all its vertices coincide, a fan without a special case.
        mesh = self.surface(x, z, origin)
        mesh["index"] = _grid_index(len(radii), segments, wrap=True)
        # Triangles come ring by ring: a band of rings is one run of the index buffer.
        mesh["rings"] = radii
        mesh["ring_center"] = np.asarray(center_xz, dtype=np.float64)
        mesh["segments"] = segments
        mesh["ripples"] = True  # the wind's ripples lie on the dunes, not on other objects
        return mesh

    def sphere_beside_view(self, eye, forward) -> tuple[np.ndarray, float] | None:
        """(centre, radius) of a sphere resting on the ground beside the point a view from
        ``eye`` along ``forward`` looks at, sized to the distance to it so it reads from a
        millimetre to a kilometre; None when the view misses the ground."""
        eye = np.asarray(eye, dtype=np.float64)
        forward = np.asarray(forward, dtype=np.float64)
        hit = self.ray_hit(eye, forward, 10.0 * self.extent_m)
        if hit is None:
            return None
        distance = float(np.linalg.norm(hit - eye))
        radius = 0.15 * distance
        side = np.cross(forward, (0.0, 1.0, 0.0))
        side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-6 else np.array([1, 0, 0])
        x, z = hit[0] + 0.35 * distance * side[0], hit[2] + 0.35 * distance * side[2]
        return np.array([x, float(self.height(x, z)) + radius, z]), radius

    def ray_hit(self, origin, direction, max_distance: float) -> np.ndarray | None:
        """First point where the ray meets the ground within ``max_distance``, or ``None``."""
        origin = np.asarray(origin, dtype=np.float64)
        direction = np.asarray(direction, dtype=np.float64)
        direction = direction / np.linalg.norm(direction)

        def above(t):
            p = origin[:, None] + direction[:, None] * np.atleast_1d(t)[None, :]
            return p[1] - self.height(p[0], p[2])

        start = above(0.0)[0]
        if start <= 0:
            return origin.copy()
        # Geometric samples: fine near the eye, where the ground may be millimetres away.
        first = max(1e-7, start * 1e-3)
        t = np.concatenate([[0.0], np.geomspace(first, max_distance, 4096)])
        below = np.nonzero(above(t) <= 0)[0]
        if below.size == 0:
            return None
        lo, hi = t[below[0] - 1], t[below[0]]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if above(mid)[0] > 0 else (lo, mid)
        return origin + direction * hi


def sphere_mesh(center, radius: float, segments: int = 32, origin=None) -> dict:
    """A UV sphere: ``uv`` in metres along the surface (longitude, latitude) and ``tangent``
    along +u (eastward in longitude)."""
    center = np.asarray(center, dtype=np.float64)
    lon = np.linspace(0.0, 2 * math.pi, segments + 1)
    lat = np.linspace(-math.pi / 2, math.pi / 2, segments // 2 + 1)
    lat_grid, lon_grid = np.meshgrid(lat, lon, indexing="ij")
    normal = np.stack(
        [
            np.cos(lat_grid) * np.cos(lon_grid),
            np.sin(lat_grid),
            np.cos(lat_grid) * np.sin(lon_grid),
        ],
        axis=-1,
    )
    # ∂/∂lon of the direction above, normalised; defined at the poles too. Longitude runs so
    # that cross(tangent, normal) points north (+v), the same handedness as the terrain's.
    tangent = np.stack([-np.sin(lon_grid), np.zeros_like(lon_grid), np.cos(lon_grid)], axis=-1)
    position = center + radius * normal
    if origin is not None:
        position = position - np.asarray(origin, dtype=np.float64)
    uv = np.stack([lon_grid * radius, lat_grid * radius], axis=-1)
    return {
        "position": position.reshape(-1, 3).astype(np.float32),
        "normal": normal.reshape(-1, 3).astype(np.float32),
        "tangent": tangent.reshape(-1, 3).astype(np.float32),
        "uv": uv.reshape(-1, 2).astype(np.float32),
        "index": _grid_index(len(lat), len(lon)),
    }


def _grid_index(rows: int, columns: int, wrap: bool = False) -> np.ndarray:
    """Two triangles per cell of a rows × columns vertex grid (row-major), row after row; with
    ``wrap`` the last column joins the first."""
    r, c = np.meshgrid(
        np.arange(rows - 1), np.arange(columns if wrap else columns - 1), indexing="ij"
    )
    r, c = r.ravel(), c.ravel()
    a = r * columns + c
    b = r * columns + (c + 1) % columns
    d, e = a + columns, b + columns
    return np.stack([a, b, e, a, e, d], axis=-1).reshape(-1).astype(np.uint32)


def _as_float64(x, z):
    return np.asarray(x, dtype=np.float64), np.asarray(z, dtype=np.float64)
