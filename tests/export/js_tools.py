"""Node-side checks of exported glTF files: the Khronos glTF validator, and three.js rendering
in headless Chromium with the frame read back as linear HDR radiance.

The Node packages and the page runner are ``sand_editor.bench.browser``'s.

Light units in three.js (r155 and later, checked in r187's sources): ``WebGLLights`` uploads a
directional light's ``color`` multiplied by its ``intensity``; ``getDirectionalLightInfo`` passes
that on unchanged as ``directLight.color``, and ``RE_Direct_Physical`` takes
``irradiance = dot(N, L) * directLight.color`` with no factor of π, so a light of intensity I
and colour c gives irradiance I·c (W/m² in the renderer's units) on a surface facing it. The
diffuse term is ``BRDF_Lambert(diffuseContribution) = baseColor·(1 - metallic)/π``, scaled by
``1 - F`` (glTF's fresnel_mix, F = F_Schlick(specularColor, specularF90, dot(V, H))), and the GGX
specular lobe is added on top. With the default F0 of 0.04 the specular part is several percent
of the diffuse one for dark colours; a material with ``KHR_materials_specular``
``specularFactor = 0`` has F = 0 and no specular lobe, and reflects exactly
baseColor/π · E · cos θ. :func:`render_threejs` therefore sets the light's colour to the
irradiance over its largest component, and its intensity to that component.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np

from sand_editor.bench.browser import (  # noqa: F401 (the tests' names for them)
    CHROMIUM,
    JS_TOOLS,
    column_major,
    js_cache_dir,
    js_root,
    require_js_root,
    run_page,
)


def validate_gltf(path: Path, timeout_s: float = 120) -> dict:
    """The Khronos glTF validator's report on a .gltf or .glb file, as a dict.

    External URIs of a .gltf are read from its folder. Useful keys: ``report["issues"]``
    ``["numErrors"]``, ``["numWarnings"]``, ``["numInfos"]``, ``["messages"]`` (each with
    ``code``, ``message``, ``severity`` (0 error … 3 hint) and ``pointer`` or ``offset``).
    Raises RuntimeError when the validator cannot run at all.
    """
    root = require_js_root()
    env = dict(os.environ, SAND_EDITOR_JS=str(root))
    result = subprocess.run(
        ["node", str(JS_TOOLS / "validate.mjs"), str(Path(path).resolve())],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout_s,
        check=False,
    )
    if result.returncode != 0:
        raise RuntimeError(f"glTF validator exited with {result.returncode}: {result.stderr}")
    return json.loads(result.stdout)


def render_threejs(
    path: Path,
    view: np.ndarray,
    projection: np.ndarray,
    sun_direction,
    sun_irradiance,
    width: int,
    height: int,
    timeout_s: float = 120,
) -> dict:
    """Renders a .glb/.gltf file with three.js in headless Chromium, lit only by the sun.

    ``view`` is the 4x4 world-to-camera matrix and ``projection`` the OpenGL clip matrix, both
    row-major numpy (applied to column vectors); ``sun_direction`` points towards the light in
    world space; ``sun_irradiance`` is the linear RGB irradiance on a surface facing the sun.

    Returns ``pixels``: float32 (height, width, 4) linear radiance and coverage (alpha 0 where
    nothing was drawn), rows top-down; ``png``: the same frame as an 8-bit sRGB PNG (no tone
    mapping); ``info``: three.js revision, WebGL version and renderer. Raises RuntimeError with
    the message of any error on the page, or when nothing comes back within ``timeout_s``.
    """
    root = require_js_root()
    model = Path(path).resolve()
    if not model.is_file():
        raise FileNotFoundError(model)
    width, height = int(width), int(height)
    if width < 1 or height < 1:
        raise ValueError(f"width and height must be positive, got {width}x{height}")
    params = {
        "model": "/model/" + model.name,
        "width": width,
        "height": height,
        "view": column_major(view, "view"),
        "projection": column_major(projection, "projection"),
        "sunDirection": [float(v) for v in np.asarray(sun_direction, dtype=np.float64)],
        "sunIrradiance": [float(v) for v in np.asarray(sun_irradiance, dtype=np.float64)],
    }
    if len(params["sunDirection"]) != 3 or len(params["sunIrradiance"]) != 3:
        raise ValueError("sun_direction and sun_irradiance must have 3 components")

    routes = {"/render.html": JS_TOOLS / "render.html", "/render.mjs": JS_TOOLS / "render.mjs"}
    trees = {"/node_modules/three/": root / "node_modules" / "three", "/model/": model.parent}
    what = f"three.js render of {model.name}"
    wanted = frozenset({"result", "png", "info"})
    posts = run_page(
        "/render.html", routes, trees, params, wanted, what, (width, height), timeout_s
    )

    raw = np.frombuffer(posts["result"], dtype=np.float32)
    if raw.size != width * height * 4:
        raise RuntimeError(f"expected {width * height * 4} floats from the page, got {raw.size}")
    pixels = raw.reshape(height, width, 4)[::-1].copy()
    return {
        "pixels": pixels,
        "png": posts["png"],
        "info": json.loads(posts["info"]),
    }


def compile_webgl2(programs: dict[str, tuple[str, str]], timeout_s: float = 120) -> dict:
    """Compiles and links each (vertex, fragment) GLSL ES 3.00 pair of ``programs`` in
    Chromium's WebGL2 (ANGLE on SwiftShader: ANGLE's own validator, then SwiftShader's
    compiler). Returns, by name: ``linked`` (bool), ``log`` (the compile and link logs) and
    ``uniforms`` (the active uniforms' names), plus ``info`` (the WebGL renderer)."""
    params = {"programs": [{"name": n, "vertex": v, "fragment": f} for n, (v, f) in
                           programs.items()]}  # fmt: skip
    routes = {"/compile.html": JS_TOOLS / "compile.html"}
    posts = run_page(
        "/compile.html",
        routes,
        {},
        params,
        frozenset({"result"}),
        "WebGL2 compile",
        timeout_s=timeout_s,
    )
    return json.loads(posts["result"])
