"""Node-side checks of exported glTF files: the Khronos glTF validator, and three.js rendering
in headless Chromium with the frame read back as linear HDR radiance.

The Node packages (``three``, ``gltf-validator``, pinned in ``tools/js/package-lock.json``)
live outside the repository, in the folder ``ensure_js_packages`` of ``tools/setup.sh``
installs and exports as ``SAND_EDITOR_JS``; :func:`js_root` finds it.

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

import hashlib
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
JS_TOOLS = REPO / "tools" / "js"
LOCK_FILE = JS_TOOLS / "package-lock.json"
CHROMIUM = os.environ.get("SAND_EDITOR_CHROMIUM", "/usr/bin/chromium")

# Headless Chromium with WebGL2 on SwiftShader (ANGLE's CPU Vulkan), which offers
# EXT_color_buffer_float; --no-sandbox because the tests may run as root.
CHROMIUM_FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
    "--disable-dev-shm-usage",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-extensions",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--mute-audio",
    "--enable-logging=stderr",
    "--v=0",
)

_CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".json": "application/json",
    ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json",
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".webp": "image/webp",
    ".ktx2": "image/ktx2",
}


def js_cache_dir() -> Path:
    """Where ``ensure_js_packages`` installs the packages of this lock file:
    ``${SAND_EDITOR_CACHE:-~/.cache/sand-editor}/js/<first 16 hex digits of its sha256>``."""
    cache = Path(os.environ.get("SAND_EDITOR_CACHE") or Path.home() / ".cache" / "sand-editor")
    digest = hashlib.sha256(LOCK_FILE.read_bytes()).hexdigest()[:16]
    return cache.resolve() / "js" / digest


def _valid(root: Path) -> bool:
    modules = root / "node_modules"
    return (modules / "three" / "package.json").is_file() and (
        modules / "gltf-validator" / "package.json"
    ).is_file()


def js_root() -> Path | None:
    """The folder whose ``node_modules`` holds three and gltf-validator: ``SAND_EDITOR_JS`` when
    set and valid, else the cache folder of the current lock file when installed; else None."""
    from_env = os.environ.get("SAND_EDITOR_JS")
    if from_env and _valid(Path(from_env)):
        return Path(from_env).resolve()
    cached = js_cache_dir()
    return cached if _valid(cached) else None


def _require_root() -> Path:
    root = js_root()
    if root is None:
        raise RuntimeError(
            f"the Node packages of tools/js are not installed (expected in {js_cache_dir()} "
            "or $SAND_EDITOR_JS): run ensure_js_packages from tools/setup.sh"
        )
    return root


def validate_gltf(path: Path, timeout_s: float = 120) -> dict:
    """The Khronos glTF validator's report on a .gltf or .glb file, as a dict.

    External URIs of a .gltf are read from its folder. Useful keys: ``report["issues"]``
    ``["numErrors"]``, ``["numWarnings"]``, ``["numInfos"]``, ``["messages"]`` (each with
    ``code``, ``message``, ``severity`` (0 error … 3 hint) and ``pointer`` or ``offset``).
    Raises RuntimeError when the validator cannot run at all.
    """
    root = _require_root()
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


def _column_major(matrix: np.ndarray, name: str) -> list[float]:
    matrix = np.asarray(matrix, dtype=np.float64)
    if matrix.shape != (4, 4) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"{name} must be a finite 4x4 matrix, got shape {matrix.shape}")
    return [float(v) for v in matrix.T.ravel()]


class _Session:
    """What the page posts back (it is done once every name in ``wanted``, or ``error``, came),
    and the files it may fetch: ``routes`` by URL path, ``trees`` by URL prefix."""

    def __init__(self, routes: dict, trees: dict, params: dict, wanted: frozenset[str]):
        self.routes = routes
        self.trees = trees
        self.wanted = wanted
        self.params = json.dumps(params).encode()
        self.posts: dict[str, bytes] = {}
        self.missing: list[str] = []
        self.done = threading.Event()
        self.lock = threading.Lock()

    def resolve(self, url_path: str) -> Path | None:
        if url_path in self.routes:
            return self.routes[url_path]
        for prefix, base in self.trees.items():
            if url_path.startswith(prefix):
                candidate = (base / url_path[len(prefix) :]).resolve()
                if candidate.is_relative_to(base.resolve()) and candidate.is_file():
                    return candidate
        return None

    def receive(self, name: str, body: bytes) -> None:
        with self.lock:
            self.posts.setdefault(name, body)
            if "error" in self.posts or self.wanted <= self.posts.keys():
                self.done.set()


def _handler(session: _Session) -> type[BaseHTTPRequestHandler]:
    from urllib.parse import unquote, urlsplit

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, format, *args):  # noqa: A002 (the base class's name)
            pass

        def _send(self, status: int, body: bytes, content_type: str) -> None:
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self):  # noqa: N802 (http.server's name)
            url_path = unquote(urlsplit(self.path).path)
            if url_path == "/params.json":
                return self._send(200, session.params, _CONTENT_TYPES[".json"])
            file = session.resolve(url_path)
            if file is None:
                if url_path != "/favicon.ico":
                    session.missing.append(url_path)
                return self._send(404, b"not found", "text/plain")
            content_type = _CONTENT_TYPES.get(file.suffix.lower(), "application/octet-stream")
            return self._send(200, file.read_bytes(), content_type)

        def do_POST(self):  # noqa: N802 (http.server's name)
            name = urlsplit(self.path).path.strip("/")
            body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
            if name not in ("result", "png", "info", "error"):
                return self._send(404, b"not found", "text/plain")
            session.receive(name, body)
            return self._send(200, b"ok", "text/plain")

    return Handler


def _console_lines(log: Path, limit: int = 20) -> str:
    try:
        lines = log.read_text(errors="replace").splitlines()
    except OSError:
        return ""
    console = [line for line in lines if "CONSOLE" in line]
    return "\n".join((console or lines)[-limit:])


def _stop(process: subprocess.Popen) -> None:
    """Ends Chromium: SIGTERM to the browser, which shuts down and reaps its helpers, then
    SIGKILL to whatever is left of its process group (its own session)."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pass
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    process.wait()


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
    root = _require_root()
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
        "view": _column_major(view, "view"),
        "projection": _column_major(projection, "projection"),
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


def run_page(
    page: str,
    routes: dict,
    trees: dict,
    params: dict,
    wanted: frozenset[str],
    what: str,
    size: tuple[int, int] = (64, 64),
    timeout_s: float = 120,
) -> dict[str, bytes]:
    """Serves ``routes`` and ``trees`` (and ``params`` as /params.json) on localhost, opens
    ``page`` in headless Chromium and returns what it posted once every name in ``wanted`` came.
    Raises RuntimeError (naming ``what``) with the page's error, or when nothing comes back."""
    session = _Session(routes, trees, params, wanted)
    server = ThreadingHTTPServer(("127.0.0.1", 0), _handler(session))
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, name="page-server", daemon=True)
    thread.start()
    profile = Path(tempfile.mkdtemp(prefix="sand-editor-chromium-"))
    log = profile / "chromium.log"
    process = None
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}{page}"
        with open(log, "wb") as log_file:
            process = subprocess.Popen(
                [
                    CHROMIUM,
                    *CHROMIUM_FLAGS,
                    f"--user-data-dir={profile / 'profile'}",
                    f"--window-size={size[0]},{size[1]}",
                    url,
                ],
                stdin=subprocess.DEVNULL,
                stdout=log_file,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
        deadline = time.monotonic() + timeout_s
        while not session.done.wait(0.1):
            if process.poll() is not None:
                raise RuntimeError(
                    f"Chromium exited with {process.returncode} before the {what} came back:\n"
                    + _console_lines(log)
                )
            if time.monotonic() > deadline:
                missing = f"; not found: {session.missing}" if session.missing else ""
                raise RuntimeError(
                    f"{what} timed out after {timeout_s} s{missing}; "
                    "Chromium's console:\n" + _console_lines(log)
                )
        if "error" in session.posts:
            raise RuntimeError(f"{what} failed: " + session.posts["error"].decode(errors="replace"))
        return dict(session.posts)
    finally:
        if process is not None:
            _stop(process)
        server.shutdown()
        server.server_close()
        shutil.rmtree(profile, ignore_errors=True)


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
