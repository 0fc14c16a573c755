"""An independent reference for the sand's mean light: Mitsuba 3 (``scalar_rgb``) path-tracing
the probe's scene with the same microsurface.

The scene is the probe's: a plane of the preset's grains seen from the probe's camera, lit by
one sun (a directional emitter of the same irradiance and direction) and no sky, direct light
only (the material models no interreflection). Its surface is Mitsuba's own microfacet model on
the generator's grain normals (a ``normalmap`` of the normal texture):

- the specular part is a ``roughconductor`` with a Beckmann distribution of the preset's facet
  roughness and the dielectric Fresnel of the grain index (a conductor of k = 0), blended over
  a black BSDF by each texel's clear weight — what the facet model claims, but evaluated about
  every grain normal by Mitsuba's own code rather than by our slope moments;
- the diffuse part is d'Eon's Lambertian-sphere BRDF per unit albedo at the tile's average
  (what the material uses), written as a Mitsuba BSDF in Python, on the same grain normals with
  each texel's albedo. The subsurface and transmission terms are compared at their neutral
  values (sss 0, transmission 0), which Mitsuba's BSDFs lack.

Ours is the probe with the same camera, sun and no sky: the specular part is mode ``glints``
with the sparkle at its expectation, the diffuse part the rest of mode ``close``, and the total
``close`` and ``far``. Means are over the frame's lower half, in HDR.
"""

from __future__ import annotations

import time

import numpy as np

from sand_editor.bench._optional import optional_module
from sand_editor.colour import LUMINANCE
from sand_editor.export.maps import clear_weights
from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.render.far_brdf import sphere_brdf

SUN_DIRECTION = np.array([0.0, 0.6, -0.8])  # towards the sun: the probe's
SUN_IRRADIANCE = np.array([3.0, 2.85, 2.6])
PITCH_DEG = 45.0
PLANE_HALF_EXTENT = 200.0  # metres: past the frame at every distance measured
_VARIANT = "scalar_rgb"
MITSUBA_USERS = "the Mitsuba reference of bench relief and appearance"


def neutral(preset: Preset) -> Preset:
    """The preset with the terms Mitsuba's scene lacks at their neutral values: subsurface and
    transmission (its BSDFs), the wind's ripples and the detail normals on them (its plane is
    the grains' normal map alone)."""
    return preset.replace(**{
        "shading.sss": 0.0, "shading.transmission": 0.0,
        "shading.ripple_strength": 0.0, "shading.detail_strength": 0.0,
    })  # fmt: skip


def load_mitsuba():
    """Mitsuba 3 in its ``scalar_rgb`` variant, with d'Eon's sphere BSDF registered."""
    dr = optional_module("drjit", MITSUBA_USERS)
    mi = optional_module("mitsuba", MITSUBA_USERS)

    if mi.variant() != _VARIANT:
        mi.set_variant(_VARIANT)
    _register_sphere_bsdf(mi, dr)
    return mi


def _deon(kd: float, ui: float, uo: float, cos_io: float) -> float:
    """d'Eon (2021), fitted BRDF of a half space of Lambertian spheres, one channel: the
    material's (render.far_brdf, the numpy form of sand_far.glsl) on plain floats."""
    return float(sphere_brdf(kd, ui, uo, cos_io))


_REGISTERED = False


def _register_sphere_bsdf(mi, dr) -> None:
    global _REGISTERED
    if _REGISTERED:
        return

    class SandSphereBSDF(mi.BSDF):
        """d'Eon's BRDF per unit albedo at a fixed mean albedo, times a texture's albedo."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.albedo = props["albedo"]
            self.mean = [float(c) for c in props["mean_albedo"]]
            reflection = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            self.m_components = [reflection]
            self.m_flags = reflection

        def _value(self, si, wo):
            ui, uo = float(wo.z), float(si.wi.z)
            if ui <= 0.0 or uo <= 0.0:
                return mi.Color3f(0.0)
            cos_io = float(dr.dot(si.wi, wo))
            kd = self.albedo.eval(si)
            per = [_deon(m, ui, uo, cos_io) / m for m in self.mean]
            return mi.Color3f(kd[0] * per[0], kd[1] * per[1], kd[2] * per[2]) * ui

        def eval(self, ctx, si, wo, active=True):
            return self._value(si, wo)

        def pdf(self, ctx, si, wo, active=True):
            return mi.warp.square_to_cosine_hemisphere_pdf(wo)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._value(si, wo), self.pdf(ctx, si, wo)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            bs.eta = 1.0
            bs.sampled_type = int(mi.BSDFFlags.DiffuseReflection)
            bs.sampled_component = 0
            value = self._value(si, wo)
            return bs, value / bs.pdf if bs.pdf > 0 else mi.Color3f(0.0)

        def to_string(self):
            return "SandSphereBSDF"

    mi.register_bsdf("sand_sphere", lambda props: SandSphereBSDF(props))
    _REGISTERED = True


def _bitmap(mi, data: np.ndarray, uv_repeat: float, raw: bool = True) -> dict:
    if data.ndim == 2:
        data = data[..., None]
    # Row 0 of our textures is v = 0; Mitsuba's bitmaps start at the top (v = 1).
    return {
        "type": "bitmap",
        "bitmap": mi.Bitmap(np.ascontiguousarray(data[::-1]).astype(np.float32)),
        "raw": raw,
        "filter_type": "nearest",
        "wrap_mode": "repeat",
        "to_uv": mi.ScalarTransform4f().scale([uv_repeat, uv_repeat, 1.0]),
    }


def mitsuba_means(preset: Preset, camera, size: tuple[int, int], spp: int, texture_size=512):
    """Mean HDR luminance of the lower half: (specular, diffuse) from Mitsuba, and seconds."""
    mi = load_mitsuba()
    textures = generate(preset, texture_size)
    shading = preset.shading
    repeat = 2.0 * PLANE_HALF_EXTENT * shading.uv_scale
    normal_map = _bitmap(mi, textures.normal * 0.5 + 0.5, repeat)
    half = PLANE_HALF_EXTENT
    # Local (x, y, 0) ∈ [−1, 1]² → world (x·L, 0, −y·L): the normal is +y, u runs along +x.
    plane = mi.ScalarTransform4f(
        [[half, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -half, 0.0, 0.0], [0, 0, 0, 1]]
    )
    eye = [float(c) for c in camera.position]
    sun = SUN_DIRECTION / np.linalg.norm(SUN_DIRECTION)
    width, height = size
    sensor = {
        "type": "perspective",
        "fov": 60.0,
        "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=[0, 0, 0], up=[0, 1, 0]),
        "film": {
            "type": "hdrfilm",
            "width": width,
            "height": height,
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
        },  # fmt: skip
        "sampler": {"type": "independent", "sample_count": spp},
    }
    specular = {
        "type": "blendbsdf",
        "weight": _bitmap(mi, clear_weights(preset, textures), repeat),
        "bsdf_0": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
        "bsdf_1": {
            "type": "roughconductor",
            "distribution": "beckmann",
            "alpha": float(shading.facet_roughness),
            "eta": float(shading.grain_ior),
            "k": 0.0,
        },  # fmt: skip
    }
    mean_albedo = np.clip(textures.average_albedo.astype(np.float64), 1e-4, 1.0)
    diffuse = {"type": "sand_sphere", "albedo": _bitmap(mi, textures.albedo, repeat),
               "mean_albedo": [float(c) for c in mean_albedo]}  # fmt: skip
    means, seconds = {}, 0.0
    for part, bsdf in (("specular", specular), ("diffuse", diffuse)):
        scene = mi.load_dict({
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
            "sensor": sensor,
            "sun": {"type": "directional", "direction": [float(-c) for c in sun],
                    "irradiance": {"type": "rgb", "value": [float(c) for c in SUN_IRRADIANCE]}},
            "plane": {"type": "rectangle", "to_world": plane,
                      "bsdf": {"type": "normalmap", "normalmap": normal_map, "bsdf": bsdf}},
        })  # fmt: skip
        start = time.perf_counter()
        image = np.array(mi.render(scene, spp=spp))
        seconds += time.perf_counter() - start
        means[part] = float((image[height // 2 :] @ LUMINANCE).mean())
    return means, seconds


def our_means(probe, camera) -> tuple[dict, float]:
    """The probe's mean HDR luminance of the lower half: specular, diffuse, close and far."""
    probe.sun_direction = SUN_DIRECTION.copy()
    probe.sun_radiance = SUN_IRRADIANCE.copy()
    probe.sky_irradiance = np.zeros(3)
    probe.glint_filter = "ours-mean"
    means, milliseconds = {}, 0.0
    for mode in ("glints", "close", "far"):
        image, ms = probe.render(camera, mode, lower_half=True)
        milliseconds += ms
        means[mode] = float((image[probe.height // 2 :] @ LUMINANCE).mean())
    probe.glint_filter = "ours"
    return {"specular": means["glints"], "diffuse": means["close"] - means["glints"],
            "close": means["close"], "far": means["far"]}, milliseconds  # fmt: skip


COMPARE_DISTANCES = (1.0, 3.0, 10.0, 30.0)


def compare(presets, distances=COMPARE_DISTANCES, size=(64, 36), spp=64, texture_size=512):
    """Ours against Mitsuba per preset and distance: mean HDR luminance of the specular part,
    the diffuse part and the total (close and far), with each side's time."""
    from sand_editor.bench.probe import MaterialProbe
    from sand_editor.gl import standalone_context
    from sand_editor.render.material import SandMaterial

    ctx = standalone_context()
    material = SandMaterial(ctx, texture_size)
    probe = MaterialProbe(material, *size)
    rows = []
    try:
        for preset in presets:
            preset = neutral(preset)
            material.update(preset)
            for distance in distances:
                camera = probe.camera(distance, PITCH_DEG)
                ours, ms = our_means(probe, camera)
                theirs, seconds = mitsuba_means(preset, camera, size, spp, texture_size)
                total = theirs["specular"] + theirs["diffuse"]
                rows.append({
                    "preset": preset.name, "distance_m": distance,
                    "ours": ours, "mitsuba": {**theirs, "total": total},
                    "specular_ratio": ours["specular"] / max(theirs["specular"], 1e-12),
                    "diffuse_ratio": ours["diffuse"] / max(theirs["diffuse"], 1e-12),
                    "close_ratio": ours["close"] / max(total, 1e-12),
                    "far_ratio": ours["far"] / max(total, 1e-12),
                    "ours_ms": ms, "mitsuba_s": seconds,
                })  # fmt: skip
    finally:
        probe.release()
        material.release()
    return rows


def format_rows(rows) -> str:
    lines = [
        "| preset | distance | specular, ours / Mitsuba | diffuse | total, close | total, far "
        "| ours (ms) | Mitsuba (s) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['preset']} | {r['distance_m']:g} m | {r['specular_ratio']:.3f} | "
            f"{r['diffuse_ratio']:.3f} | {r['close_ratio']:.3f} | {r['far_ratio']:.3f} | "
            f"{r['ours_ms']:.0f} | {r['mitsuba_s']:.1f} |"
        )
    return "\n".join(lines)
