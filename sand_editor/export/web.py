"""``sand-editor export PRESET --format web --out DIR``: the sand as a static WebGL2/WebXR page.

The page draws what the renderer draws, with the renderer's own programs: every shader is our
GLSL as GLSL ES 3.00 (``gl.shader_text(dialect="es")``), never a hand copy, and every uniform the
material and the renderer set comes from the code that sets them here
(``SandMaterial.uniform_values``, ``sky_uniforms``, ``SandRenderer.surface_switches``). The
textures are the material's own, read back level by level (the glint moments as 32-bit floats),
the dunes the terrain's rings around the page's origin, and the day a table of skies, one every
``SKY_STEP_MINUTES``, each with the light's exposure.

The folder holds ``index.html`` and ``sand-viewer.js`` (the viewer, in ``web_viewer/``),
``scene.json`` (written last: it marks the folder complete) and one ``.bin`` per texture and for
the terrain. Not carried: the shadow maps (the page lights without them) and the exposure's
metering of the frame (the page exposes for the light, as the renderer does at a fixed exposure).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import moderngl
import numpy as np

from sand_editor import gl
from sand_editor.files import write_folder
from sand_editor.generator.sizes import DEFAULT_RENDER_SIZE
from sand_editor.preset import Preset
from sand_editor.render.exposure import light_exposure
from sand_editor.render.material import SandMaterial, surface_defines
from sand_editor.render.post import BLOOM_LEVELS, UPSAMPLE_RADIUS
from sand_editor.render.renderer import SKY_CONSTANTS, SURFACE_SKY, SandRenderer, sky_uniforms
from sand_editor.render.sky import sky_at
from sand_editor.render.terrain import DuneTerrain
from sand_editor.vr.actions import SCRUB_HOURS_PER_S, STICK_DEAD_ZONE
from sand_editor.vr.locomotion import SNAP_TURN_DEG, STICK_ENGAGE, STICK_RELEASE

VIEWER_DIR = Path(__file__).resolve().parent / "web_viewer"
VIEWER_FILES = ("index.html", "sand-viewer.js")
SCENE_FILE = "scene.json"
SCENE_VERSION = 1
SKY_STEP_MINUTES = 10
# The page's dunes: rings around its origin from this spacing out to the renderer's horizon,
# fine enough under a camera 0.1 m from the sand there and no coarser than the renderer's
# meshes anywhere a standing viewer looks.
TERRAIN_INNER_M = 1.0 / 256.0
TERRAIN_SEGMENTS = 96
# Walking in VR: within this radius of the origin, where the dunes' rings are fine enough that
# the ground the page stands you on (its heights, sampled from the terrain) is the ground drawn.
WALK_RADIUS_M = 40.0
WALK_SPEED_M_S = 1.4  # at full stick
HEIGHT_SAMPLES = 161  # per edge of the walkable square: 0.5 m apart
_VERTEX_ATTRIBUTES = (("a_position", 3), ("a_normal", 3), ("a_tangent", 3), ("a_uv", 2))
# moderngl texture dtype and components → WebGL2 (internal format, format, type, typed array).
_WEB_FORMATS = {
    ("f4", 1): ("R32F", "RED", "FLOAT", "Float32Array"),
    ("f4", 2): ("RG32F", "RG", "FLOAT", "Float32Array"),
    ("f4", 4): ("RGBA32F", "RGBA", "FLOAT", "Float32Array"),
    ("f2", 4): ("RGBA16F", "RGBA", "HALF_FLOAT", "Uint16Array"),
    ("u4", 2): ("RG32UI", "RG_INTEGER", "UNSIGNED_INT", "Uint32Array"),
}
_FILTERS = {
    moderngl.NEAREST: "NEAREST",
    moderngl.LINEAR: "LINEAR",
    moderngl.LINEAR_MIPMAP_LINEAR: "LINEAR_MIPMAP_LINEAR",
    moderngl.NEAREST_MIPMAP_NEAREST: "NEAREST_MIPMAP_NEAREST",
    moderngl.LINEAR_MIPMAP_NEAREST: "LINEAR_MIPMAP_NEAREST",
    moderngl.NEAREST_MIPMAP_LINEAR: "NEAREST_MIPMAP_LINEAR",
}
# The programs the page draws with: file, defines (as the renderer and post chain compile them).
_PROGRAMS = {
    "surface": ("terrain.glsl", surface_defines()),
    "surface_far": ("terrain.glsl", surface_defines(SAND_FAR_ONLY=1)),
    "sky": ("sky.glsl", {}),
}
_POST_PROGRAMS = {
    "bloom_down": {"BLOOM_DOWNSAMPLE": 1},
    "bloom_up": {"BLOOM_UPSAMPLE": 1},
    "resolve": {"RESOLVE": 1},
}


def programs() -> dict[str, dict[str, str]]:
    """Every program of the page as GLSL ES 3.00 vertex and fragment text."""
    result = {}
    for name, (file, defines) in _PROGRAMS.items():
        result[name] = {
            "vertex": gl.shader_text(file, {**defines, "VERTEX_SHADER": 1}, dialect="es"),
            "fragment": gl.shader_text(file, {**defines, "FRAGMENT_SHADER": 1}, dialect="es"),
        }
    vertex = gl.shader_text("fullscreen.vert", dialect="es")
    for name, defines in _POST_PROGRAMS.items():
        fragment = gl.shader_text("post.glsl", defines, dialect="es")
        result[name] = {"vertex": vertex, "fragment": fragment}
    return result


def _texture_levels(texture) -> int:
    mipmapped = texture.filter[0] not in (moderngl.NEAREST, moderngl.LINEAR)
    if not mipmapped:
        return 1
    return int(math.log2(max(texture.size[:2]))) + 1


def texture_entry(name: str, texture, file: str) -> tuple[dict, bytes]:
    """A texture as the page uploads it (every mip level, one after another) and its data."""
    key = (texture.dtype, texture.components)
    if key not in _WEB_FORMATS:
        raise ValueError(f"{name}: no WebGL2 format for a {key[1]}-component {key[0]} texture")
    internal, fmt, kind, array = _WEB_FORMATS[key]
    three_d = len(texture.size) == 3
    levels, chunks, offset = [], [], 0
    for level in range(_texture_levels(texture)):
        size = [max(1, side >> level) for side in texture.size]
        data = texture.read() if three_d else texture.read(level=level, alignment=1)
        levels.append({"size": size, "offset": offset, "bytes": len(data)})
        chunks.append(data)
        offset += len(data)
    entry = {
        "uniform": name,
        "file": file,
        "target": "TEXTURE_3D" if three_d else "TEXTURE_2D",
        "internal_format": internal,
        "format": fmt,
        "type": kind,
        "array": array,
        "levels": levels,
        "min_filter": _FILTERS[texture.filter[0]],
        "mag_filter": _FILTERS[texture.filter[1]],
        "repeat": bool(texture.repeat_x),
    }
    return entry, b"".join(chunks)


def terrain_entry(terrain: DuneTerrain) -> tuple[dict, bytes, bytes]:
    """The dunes as rings around the origin: interleaved float32 vertices, uint32 indices."""
    origin = np.array([0.0, float(terrain.height(0.0, 0.0)), 0.0])
    mesh = terrain.radial_mesh(
        (0.0, 0.0), TERRAIN_INNER_M, terrain.extent_m, TERRAIN_SEGMENTS, origin=origin
    )
    columns = [mesh[name.removeprefix("a_")] for name, _ in _VERTEX_ATTRIBUTES]
    vertices = np.hstack(columns).astype(np.float32)
    indices = mesh["index"].astype(np.uint32)
    entry = {
        "vertices": "terrain-vertices.bin",
        "indices": "terrain-indices.bin",
        "attributes": [{"name": n, "size": s} for n, s in _VERTEX_ATTRIBUTES],
        "stride_floats": int(vertices.shape[1]),
        "vertex_count": int(vertices.shape[0]),
        "index_count": int(indices.size),
        "origin": [float(v) for v in origin],
        "no_ripples": 0.0,
    }
    return entry, vertices.tobytes(), indices.tobytes()


def locomotion_entry(terrain: DuneTerrain) -> tuple[dict, bytes]:
    """How the page moves a headset about, with the VR viewer's own stick thresholds, and the
    ground's heights over the walkable square (rows along z, columns along x, float32)."""
    axis = np.linspace(-WALK_RADIUS_M, WALK_RADIUS_M, HEIGHT_SAMPLES)
    z, x = np.meshgrid(axis, axis, indexing="ij")
    heights = np.asarray(terrain.height(x, z), dtype=np.float32)
    entry = {
        "heights": "terrain-heights.bin",
        "samples": HEIGHT_SAMPLES,
        "walk_radius_m": WALK_RADIUS_M,
        "walk_speed_m_s": WALK_SPEED_M_S,
        "snap_turn_deg": SNAP_TURN_DEG,
        "stick_engage": STICK_ENGAGE,
        "stick_release": STICK_RELEASE,
        "dead_zone": STICK_DEAD_ZONE,
        "scrub_hours_per_s": SCRUB_HOURS_PER_S,
    }
    return entry, heights.tobytes()


def sky_table(step_minutes: int = SKY_STEP_MINUTES) -> list[dict]:
    """The sky every ``step_minutes`` from midnight to midnight (both ends), with the light's
    exposure, as the sky and surface programs' uniforms."""
    table = []
    for minute in range(0, 24 * 60 + 1, step_minutes):
        sky = sky_at(minute / 60.0)
        table.append(
            {"hours": minute / 60.0, "exposure": light_exposure(sky), "uniforms": sky_uniforms(sky)}
        )
    return table


def scene_files(preset: Preset, ctx, texture_size: int = DEFAULT_RENDER_SIZE) -> dict[str, bytes]:
    """Every file of the page but the viewer's own, ``scene.json`` last."""
    scene, files = scene_data(preset, ctx, texture_size)
    return {**files, SCENE_FILE: scene_json(scene)}


def scene_json(scene: dict) -> bytes:
    """``scene.json``'s bytes. JSON writes the uniforms' tuples as arrays, and refuses a NaN or
    inf outright."""
    return json.dumps(scene, separators=(",", ":"), allow_nan=False).encode()


def scene_data(
    preset: Preset, ctx, texture_size: int = DEFAULT_RENDER_SIZE, with_programs: bool = True
) -> tuple[dict, dict[str, bytes]]:
    """The scene (what ``scene.json`` holds) and the data files it names (without the page's
    programs for a port that makes its own from the GLSL, the Godot export)."""
    material = SandMaterial(ctx, texture_size)
    renderer = SandRenderer(ctx)
    try:
        material.update(preset)
        files: dict[str, bytes] = {}
        textures = []
        for name, texture in material.textures().items():
            file = f"texture-{name.removeprefix('u_').replace('_', '-')}.bin"
            entry, data = texture_entry(name, texture, file)
            textures.append(entry)
            files[file] = data
        terrain, vertices, indices = terrain_entry(renderer.terrain)
        files[terrain["vertices"]] = vertices
        files[terrain["indices"]] = indices
        locomotion, heights = locomotion_entry(renderer.terrain)
        files[locomotion["heights"]] = heights
        scene = {
            "version": SCENE_VERSION,
            "preset": preset.name,
            "preset_document": preset.to_dict(),
            **({"programs": programs()} if with_programs else {}),
            "material": {"uniforms": material.uniform_values(), "textures": textures},
            "surface": {"switches": renderer.surface_switches("full"), "sky": list(SURFACE_SKY)},
            "terrain": terrain,
            "locomotion": locomotion,
            "sky": {"constants": SKY_CONSTANTS, "table": sky_table()},
            "post": {
                "bloom_levels": BLOOM_LEVELS,
                "bloom_strength": renderer.bloom_strength,
                "upsample_radius": UPSAMPLE_RADIUS,
            },
        }
        return scene, files
    finally:
        renderer.release()
        material.release()


def viewer_files() -> dict[str, bytes]:
    return {name: (VIEWER_DIR / name).read_bytes() for name in VIEWER_FILES}


def export_web(preset: Preset, out: Path, texture_size: int = DEFAULT_RENDER_SIZE, ctx=None):
    """Write the page into the folder ``out`` as one unit; returns the files' names and bytes."""
    ctx = ctx or gl.standalone_context()
    files = {**viewer_files(), **scene_files(preset, ctx, texture_size)}
    write_folder(out, files)
    return {name: len(data) for name, data in files.items()}
