"""``sand-editor bench relief``: the grains' relief up close (parallax and self-shadowing,
shaders/sand_relief.glsl) against Mitsuba 3 (``scalar_rgb``) path-tracing the same height field
as real geometry, under a low sun, direct light only.

The geometry is the one the relief models: one tile of the generator's grains as a mesh with a
vertex at every texel's centre, (1 − alpha) · RELIEF_DEPTH_CELLS grain cells below the plane
y = 0 (alpha: the albedo texture's relief height as material_build.frag makes it, 1 at the top
of the tallest grain, 0 in gaps), seamless across the tile's edge. Its shading normals are the
grain normals (tangent space (x, y, z) is world (x, z, y): u along +x, v along +z, as on the
probe's plane); its albedo and share of clear facets are vertex attributes, interpolated
across each triangle as our textures are between texels. The frames see a few centimetres
around the tile's centre: one tile holds them and the shadows cast into them. The surface is
mitsuba_reference's: d'Eon's Lambertian-sphere BRDF per unit albedo at the tile's average plus
a Beckmann ``roughconductor`` (facet roughness, grain index) weighted by the clear share,
summed as a ``blendbsdf`` of both at twice their weight. The terms Mitsuba lacks are neutral
(sss and transmission 0) and the ripples off (the mesh is a flat tile). "Flat" is that mesh
at y = 0 in Mitsuba, ``u_relief = 0`` in ours: the probe (:class:`MaterialProbe`) in mode
``close``, the sparkle at its expectation (glint filter ``ours-mean``), the same camera and
sun, no sky or moon. Both take one sample per pixel (Mitsuba's jittered in the pixel).

The camera looks down at PITCH_DEG at the tile's centre; its frame is the central W×H pixels
of a 60° frame FRAME_LINES tall, so that a grain cell spans about 20 (5 cm) and 10 (30 cm)
pixels and the relief is at full weight (it fades in from 2 to 5). The sun stands
SUN_AZIMUTH_DEG right of the view's heading: shadows run across the frame, parallax along it.

Each preset is rendered in three copies with the same grains (colours do not move them): its
own colours, for the mean radiance (the mean luminance over the frame); grey, every colour the
tile's average and no layer darkening, so that dark grains are not taken for shadow; and grey
and smooth, every grain normal up and no clear facets, where only the geometry darkens the
sand. Against each pixel's flat light (what an unshadowed upward surface of that albedo sends
its eye under that sun, d'Eon's BRDF):

- in shadow: the share of the smooth copy's pixels below CAST_FRACTION of their flat light,
  cast and geometric shadows alone. Mitsuba's are hard (its sun is a direction), ours soft,
  so the threshold is the penumbra's middle; the light lost to shadow (1 − the mean ratio to
  the flat light) is kept too;
- dark: the share of the grey copy's pixels below DARK_FRACTION of their flat light, the grain
  normals' attached shadows included.
"""

from __future__ import annotations

import math
import re
import sys
import time
from dataclasses import replace

import numpy as np

from sand_editor.bench import mitsuba_reference as reference
from sand_editor.bench._optional import optional_module
from sand_editor.bench.mitsuba_reference import SUN_IRRADIANCE
from sand_editor.colour import LUMINANCE, linear_to_srgb
from sand_editor.generator import generate
from sand_editor.preset import Preset
from sand_editor.resources import bundled_preset, shader_source

PRESETS = ("paper-default", "black-volcanic", "pale-quartz", "red-desert")
QUICK_PRESETS = ("paper-default",)
DISTANCES = (0.05, 0.3)
SUN_ELEVATIONS = (10.0, 30.0)
SUN_AZIMUTH_DEG = 90.0
PITCH_DEG = 45.0
FRAME_FOV_DEG = 60.0
FRAME_LINES = {0.05: 480, 0.3: 1440}
SIZE, QUICK_SIZE, SHEET_CROP = (320, 180), (160, 90), (160, 90)  # the sheet: each frame's middle
TEXTURE_SIZE = 512
SHOWN = (("mitsuba", "relief"), ("ours", "relief"), ("ours", "flat"))
CAST_FRACTION = 0.5
DARK_FRACTION = 0.2


def _shader_constant(file: str, name: str) -> float:
    match = re.search(rf"const float {name} = ([0-9.eE+-]+);", shader_source(file))
    if match is None:
        raise RuntimeError(f"{file} defines no float {name}")
    return float(match.group(1))


def relief_heights(textures) -> np.ndarray:
    """The relief height of every texel (the albedo texture's alpha): the grain's profile over
    the tallest a profile gets, lower by LAYER_RELIEF for each layer deeper, 0 in gaps."""
    from sand_editor.render.material import SHADER_DEFINES

    layer_relief = _shader_constant("material_build.frag", "LAYER_RELIEF")
    layer = textures.layer.astype(np.int64)
    height = textures.height / float(SHADER_DEFINES["PROFILE_TOP"]) * layer_relief**layer
    return np.clip(np.where(layer >= 0, height, 0.0), 0.0, 1.0)


def relief_mesh(textures, uv_scale: float, flat: bool = False, weights=None) -> dict:
    """One tile of grains as a triangle mesh, world metres: (n+1)² vertices at the texel
    centres (the last row and column the first again, one tile on), y = (alpha − 1) · depth
    (0 for ``flat``), world shading normals, and per vertex the albedo and clear share."""
    n = textures.size
    tile = 1.0 / uv_scale
    cell = tile / textures.generation.period
    depth = _shader_constant("sand_relief.glsl", "RELIEF_DEPTH_CELLS") * cell
    wrap = np.arange(n + 1) % n

    def per_vertex(a: np.ndarray) -> np.ndarray:
        return a[np.ix_(wrap, wrap)].reshape((n + 1) ** 2, *a.shape[2:])

    row, column = np.divmod(np.arange((n + 1) ** 2), n + 1)  # row: v, column: u
    y = np.zeros(row.size) if flat else (per_vertex(relief_heights(textures)) - 1.0) * depth
    positions = np.stack([(column + 0.5) / n * tile, y, (row + 0.5) / n * tile], axis=-1)
    normal = per_vertex(textures.normal)
    normals = np.stack([normal[:, 0], normal[:, 2], normal[:, 1]], axis=-1)
    a = (row * (n + 1) + column).reshape(n + 1, n + 1)[:-1, :-1].ravel()
    b, c, d = a + 1, a + n + 1, a + n + 2  # +u, +v, both
    faces = np.concatenate([np.stack([a, c, b], -1), np.stack([b, c, d], -1)])  # facing +y
    clear = np.zeros((n, n)) if weights is None else weights
    return {
        "positions": positions.astype(np.float32),
        "normals": (normals / np.linalg.norm(normals, axis=-1, keepdims=True)).astype(np.float32),
        "faces": faces.astype(np.uint32),
        "albedo": per_vertex(textures.albedo).astype(np.float32),
        "clear": np.repeat(per_vertex(clear)[:, None], 3, axis=1).astype(np.float32),
        "depth_m": depth,
    }


def _mitsuba_mesh(mi, arrays: dict, preset, mean_albedo):
    dr = optional_module("drjit", reference.MITSUBA_USERS)
    positions, faces = arrays["positions"], arrays["faces"]
    mesh = mi.Mesh("grains", len(positions), len(faces), has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = dr.scalar.ArrayXf(positions.ravel())
    params["vertex_normals"] = dr.scalar.ArrayXf(arrays["normals"].ravel())
    params["faces"] = dr.scalar.ArrayXu(faces.ravel())
    params.update()
    for name in ("albedo", "clear"):
        mesh.add_attribute(f"vertex_{name}", 3, dr.scalar.ArrayXf(arrays[name].ravel()))
    shading = preset.shading

    def twice(name: str) -> dict:
        return {"type": "mesh_attribute", "name": f"vertex_{name}", "scale": 2.0}

    mesh.set_bsdf(mi.load_dict({
        "type": "blendbsdf", "weight": 0.5,
        "bsdf_0": {"type": "sand_sphere", "albedo": twice("albedo"),
                   "mean_albedo": [float(c) for c in mean_albedo]},
        "bsdf_1": {"type": "roughconductor", "distribution": "beckmann",
                   "alpha": float(shading.facet_roughness), "eta": float(shading.grain_ior),
                   "k": 0.0, "specular_reflectance": twice("clear")},
    }))  # fmt: skip
    return mesh


def sun_direction(elevation_deg: float) -> np.ndarray:
    """Towards the sun, world: SUN_AZIMUTH_DEG clockwise from the view's heading (−z)."""
    e, a = math.radians(elevation_deg), math.radians(SUN_AZIMUTH_DEG)
    return np.array([math.sin(a) * math.cos(e), math.sin(e), -math.cos(a) * math.cos(e)])


def view(distance: float, size: tuple[int, int], tile: float):
    """The camera at ``distance`` (its frame the middle of a FRAME_LINES-line 60° frame) and
    its vertical field of view in degrees."""
    from sand_editor.render.camera import camera_at_distance

    half = math.tan(math.radians(FRAME_FOV_DEG / 2)) * size[1] / FRAME_LINES[distance]
    fov = math.degrees(2.0 * math.atan(half))
    camera = camera_at_distance(distance, PITCH_DEG, size[0] / size[1],
                                target_xz=(tile / 2, tile / 2), fov_y_deg=fov)  # fmt: skip
    return camera, fov


def ground_hits(camera, size: tuple[int, int], pixels=None) -> np.ndarray:
    """Where pixel centres' rays (column, row from the top) meet y = 0, world (…, 3)."""
    w, h = size
    if pixels is None:
        pixels = np.stack(np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5), axis=-1)
    pixels = np.asarray(pixels, dtype=np.float64)
    ndc = np.stack([2 * pixels[..., 0] / w - 1, 1 - 2 * pixels[..., 1] / h], axis=-1)
    clip = np.concatenate([ndc, np.ones_like(ndc)], axis=-1)  # a point on the far plane
    world = clip @ np.linalg.inv(camera.view_projection.astype(np.float64)).T
    ray = world[..., :3] / world[..., 3:] - camera.eye
    return camera.eye + ray * (-camera.eye[1] / ray[..., 1:2])


def cell_pixels(camera, size: tuple[int, int], cell_m: float) -> float:
    """A grain cell's edge in pixels at the frame's centre, along its shorter way (the relief's
    fade measures the same)."""
    cx, cy = size[0] / 2, size[1] / 2
    p = ground_hits(camera, size, [[cx, cy], [cx + 1, cy], [cx, cy + 1]])
    return cell_m / max(np.linalg.norm(p[1] - p[0]), np.linalg.norm(p[2] - p[0]))


def flat_luminance(camera, size, sun: np.ndarray, albedo) -> np.ndarray:
    """Per pixel, the luminance an unshadowed upward surface of ``albedo`` sends the eye."""
    to_eye = camera.eye - ground_hits(camera, size)
    to_eye /= np.linalg.norm(to_eye, axis=-1, keepdims=True)
    ui, uo, cos_io = sun[1], to_eye[..., 1], to_eye @ sun
    deon = np.vectorize(reference._deon, otypes=[float])
    pairs = zip(albedo, SUN_IRRADIANCE, strict=True)
    rgb = [deon(float(k), ui, uo, cos_io) * ui * e for k, e in pairs]
    return np.stack(rgb, axis=-1) @ LUMINANCE


def mitsuba_image(mi, mesh, camera, fov: float, size, sun: np.ndarray) -> tuple[np.ndarray, float]:
    """Mitsuba's HDR frame (rows top-down), one sample per pixel, and its seconds (the
    scene's building included)."""
    eye = [float(c) for c in camera.eye]
    target = [float(c) for c in camera.eye + camera.forward]
    start = time.perf_counter()
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {"type": "perspective", "fov": fov, "fov_axis": "y", "near_clip": 1e-4,
                   "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=target,
                                                              up=[0.0, 1.0, 0.0]),
                   "film": {"type": "hdrfilm", "width": size[0], "height": size[1],
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": 1}},
        "sun": {"type": "directional", "direction": [float(-c) for c in sun],
                "irradiance": {"type": "rgb", "value": [float(c) for c in SUN_IRRADIANCE]}},
        "grains": mesh,
    })  # fmt: skip
    image = np.array(mi.render(scene, spp=1), dtype=np.float64)
    return image, time.perf_counter() - start


def copies(preset, textures) -> dict:
    """The preset's three copies (module docstring) and their grains: {name: (preset, grains)}."""
    from sand_editor.preset import Color

    rgb = np.round(linear_to_srgb(np.asarray(textures.average_albedo)) * 255).astype(int)
    colour = Color(*(int(c) for c in rgb))
    palette = (colour,) * len(preset.generation.colors)
    grey = preset.replace(**{"generation.base_color": colour, "generation.layer_darkness": 0.0,
                             "generation.colors": palette})  # fmt: skip
    grey_textures = generate(grey, textures.size)
    if not np.array_equal(grey_textures.height, textures.height):
        raise RuntimeError(f"{preset.name}: the grey copy's grains moved")
    up = np.zeros_like(textures.normal)
    up[..., 2] = 1.0
    return {"colour": (preset, textures), "grey": (grey, grey_textures),
            "smooth": (grey.replace(**{"shading.clear_grains": 0.0}),
                       replace(grey_textures, normal=up))}  # fmt: skip


def render_views(mi, probe, preset, textures, views: dict) -> dict:
    """Per view: the frames {(renderer, "relief" | "flat"): HDR image}, Mitsuba's seconds and
    our milliseconds."""
    probe.material.update(preset, grains=textures)
    mean_albedo = np.clip(textures.average_albedo.astype(np.float64), 1e-4, 1.0)
    weights = reference.clear_weights(preset, textures)
    uv_scale = preset.shading.uv_scale
    meshes = {flat: _mitsuba_mesh(mi, relief_mesh(textures, uv_scale, flat, weights), preset,
                                  mean_albedo) for flat in (False, True)}  # fmt: skip
    size = (probe.width, probe.height)
    for relief in (True, False):  # warm: the first draws compile
        probe.relief = relief
        probe.render(next(iter(views.values()))[0], "close")
    out = {}
    for key, (camera, fov, sun) in views.items():
        probe.sun_direction = sun
        frames, seconds, ms = {}, 0.0, 0.0
        for flat, kind in ((False, "relief"), (True, "flat")):
            frames["mitsuba", kind], s = mitsuba_image(mi, meshes[flat], camera, fov, size, sun)
            probe.relief = not flat
            image, t = probe.render(camera, "close")
            frames["ours", kind] = image.astype(np.float64)
            seconds, ms = seconds + s, ms + t
        out[key] = (frames, seconds, ms)
    probe.relief = False
    return out


def measure(rendered: dict, flat_light: np.ndarray) -> dict:
    """The bench's numbers of one view from its frames ({copy: frames}, module docstring)."""

    def per(copy, value) -> dict:
        return {f"{who}_{kind}": float(value(image @ LUMINANCE))
                for (who, kind), image in rendered[copy].items()}  # fmt: skip

    mean = per("colour", np.mean)
    theirs = max(mean["mitsuba_relief"], 1e-12)
    return {
        "in_shadow": per("smooth", lambda y: np.mean(y < CAST_FRACTION * flat_light)),
        "light_lost": per("smooth", lambda y: 1.0 - np.mean(y / flat_light)),
        "dark": per("grey", lambda y: np.mean(y < DARK_FRACTION * flat_light)),
        "mean_luminance": mean,
        "ratio_relief": mean["ours_relief"] / theirs,
        "ratio_flat": mean["ours_flat"] / theirs,
        "ratio_flat_to_flat": mean["ours_flat"] / max(mean["mitsuba_flat"], 1e-12),
    }


def run(quick: bool = False) -> tuple[dict, dict]:
    """The rows of the table, and the frames of the contact sheet by (preset, distance, sun)."""
    from sand_editor.bench.generator import machine_description
    from sand_editor.bench.probe import MaterialProbe
    from sand_editor.gl import standalone_context
    from sand_editor.render.material import SandMaterial

    mi = reference.load_mitsuba()
    size = QUICK_SIZE if quick else SIZE
    ctx = standalone_context()
    material = SandMaterial(ctx, TEXTURE_SIZE)
    probe = MaterialProbe(material, *size)
    probe.sky_irradiance = np.zeros(3)
    probe.sun_radiance = np.asarray(SUN_IRRADIANCE, dtype=np.float64)
    probe.glint_filter = "ours-mean"
    rows, sheet = [], {}
    try:
        for name in QUICK_PRESETS if quick else PRESETS:
            preset = reference.neutral(Preset.load(bundled_preset(name)))
            textures = generate(preset, TEXTURE_SIZE)
            tile = 1.0 / preset.shading.uv_scale
            views = {}
            for distance in DISTANCES:
                camera, fov = view(distance, size, tile)
                for elevation in SUN_ELEVATIONS:
                    views[distance, elevation] = (camera, fov, sun_direction(elevation))
            made = copies(preset, textures)
            rendered = {copy: render_views(mi, probe, p, t, views)
                        for copy, (p, t) in made.items()}  # fmt: skip
            cell = tile / textures.generation.period
            albedo = np.clip(made["grey"][1].average_albedo.astype(np.float64), 1e-4, 1.0)
            for key, (camera, _fov, sun) in views.items():
                flat_light = flat_luminance(camera, size, sun, albedo)
                frames = {copy: r[key][0] for copy, r in rendered.items()}
                rows.append({
                    "preset": name, "distance_m": key[0], "sun_elevation_deg": key[1],
                    "cell_px": cell_pixels(camera, size, cell),
                    "flat_luminance": float(flat_light.mean()),
                    **measure(frames, flat_light),
                    "mitsuba_s": sum(r[key][1] for r in rendered.values()),
                    "ours_ms": sum(r[key][2] for r in rendered.values()),
                })  # fmt: skip
                smooth = [frames["smooth"][w, "relief"] for w in ("mitsuba", "ours")]
                sheet[(name, *key)] = [[frames["colour"][w, k] for w, k in SHOWN], smooth]
            print(f"  relief: {name}", file=sys.stderr, flush=True)
    finally:
        probe.release()
        material.release()
    results = {"machine": machine_description(ctx), "size": list(size), "pitch_deg": PITCH_DEG,
               "sun_azimuth_deg": SUN_AZIMUTH_DEG, "texture_size": TEXTURE_SIZE, "rows": rows,
               "cast_fraction": CAST_FRACTION, "dark_fraction": DARK_FRACTION}  # fmt: skip
    return results, sheet


def format_table(results: dict) -> str:
    w, h = results["size"]
    lines = [
        f"Relief against Mitsuba 3 on the displaced grains: {w}×{h}, pitch "
        f"{results['pitch_deg']:g}°, sun {results['sun_azimuth_deg']:g}° right of the view. "
        f"In shadow: below {results['cast_fraction']:g}× the flat light, smooth grey copy; "
        f"dark: below {results['dark_fraction']:g}×, grey copy (Mitsuba / ours relief / ours "
        "flat); mean radiance of the preset, ours / Mitsuba's (with relief, or flat too)",
        "",
        "| preset | distance | sun | cell px | in shadow | dark | mean, relief | mean, flat "
        "| flat / Mitsuba flat | Mitsuba (s) | ours (ms) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in results["rows"]:
        shares = [
            " / ".join(f"{r[m][k]:.3f}" for k in ("mitsuba_relief", "ours_relief", "ours_flat"))
            for m in ("in_shadow", "dark")
        ]
        lines.append(
            f"| {r['preset']} | {100 * r['distance_m']:g} cm | {r['sun_elevation_deg']:g}° | "
            f"{r['cell_px']:.1f} | {shares[0]} | {shares[1]} | {r['ratio_relief']:.3f} | "
            f"{r['ratio_flat']:.3f} | {r['ratio_flat_to_flat']:.3f} | {r['mitsuba_s']:.1f} | "
            f"{r['ours_ms']:.0f} |"
        )
    return "\n".join(lines)


def contact_sheet(frames: dict, path: str) -> None:
    """Per view (rows), the middle SHEET_CROP of its frames: Mitsuba, ours with relief and ours
    flat in the preset's colours, then Mitsuba and ours with relief on the smooth grey copy;
    each group at one exposure (its first frame's mean at mid grey), Reinhard, sRGB."""
    from PIL import Image

    groups = list(frames.values())
    (h, w), (full_h, full_w) = SHEET_CROP[::-1], groups[0][0][0].shape[:2]
    crop = np.s_[(full_h - h) // 2 : (full_h + h) // 2, (full_w - w) // 2 : (full_w + w) // 2]
    sheet = Image.new("RGB", (w * sum(map(len, groups[0])), h * len(groups)))
    for row, view_groups in enumerate(groups):
        column = 0
        for group in view_groups:
            exposure = 0.18 / max(float((group[0] @ LUMINANCE).mean()), 1e-6)
            for image in group:
                x = image[crop] * exposure
                encoded = (linear_to_srgb(x / (1.0 + x)) * 255 + 0.5).astype(np.uint8)
                sheet.paste(Image.fromarray(encoded), (column * w, row * h))
                column += 1
    sheet.save(path, optimize=True)


def main(quick: bool = False, json_path: str | None = None, plot_path: str | None = None) -> int:
    from sand_editor.bench._report import report

    results, frames = run(quick)
    return report(results, format_table, lambda _r, p: contact_sheet(frames, p), json_path,
                  plot_path)  # fmt: skip
