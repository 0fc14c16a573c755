"""Headless Chromium pages for the benchmarks and the tests: serve files and parameters on
localhost, open a page, and take back what it posts (``run_page``). Chromium draws WebGL2 on
SwiftShader (ANGLE's CPU Vulkan), so this runs on machines with no GPU and no display.

The Node packages of ``tools/js`` (three.js, the glTF validator, Meta's WebXR emulator ``iwer``;
pinned in ``tools/js/package-lock.json``) live outside the repository, in the folder
``ensure_js_packages`` of ``tools/setup.sh`` installs and exports as ``SAND_EDITOR_JS``;
:func:`js_root` finds it. The pages themselves are ``tools/js``'s: a checkout's, not a wheel's.
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
# What ensure_js_packages installs, each checked by its package.json.
JS_PACKAGES = ("three", "gltf-validator", "iwer")

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
    ".bin": "application/octet-stream",
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
    return all((modules / name / "package.json").is_file() for name in JS_PACKAGES)


def js_root() -> Path | None:
    """The folder whose ``node_modules`` holds JS_PACKAGES: ``SAND_EDITOR_JS`` when
    set and valid, else the cache folder of the current lock file when installed; else None."""
    from_env = os.environ.get("SAND_EDITOR_JS")
    if from_env and _valid(Path(from_env)):
        return Path(from_env).resolve()
    cached = js_cache_dir()
    return cached if _valid(cached) else None


def require_js_root() -> Path:
    root = js_root()
    if root is None:
        raise RuntimeError(
            f"the Node packages of tools/js are not installed (expected in {js_cache_dir()} "
            "or $SAND_EDITOR_JS): run ensure_js_packages from tools/setup.sh"
        )
    return root


def column_major(matrix, name: str) -> list[float]:
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
    routes = {"/page.mjs": JS_TOOLS / "page.mjs", **routes}  # what every page shares
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


def screenshot(url: str, size: tuple[int, int], budget_ms: int = 30000, timeout_s: float = 180):
    """A PNG of ``url`` in headless Chromium after ``budget_ms`` of the page's (virtual) time,
    and what its console said: (png bytes, console lines)."""
    profile = Path(tempfile.mkdtemp(prefix="sand-editor-chromium-"))
    out = profile / "page.png"
    try:
        result = subprocess.run(
            [CHROMIUM, *CHROMIUM_FLAGS, f"--user-data-dir={profile / 'profile'}",
             f"--window-size={size[0]},{size[1]}", f"--virtual-time-budget={budget_ms}",
             f"--screenshot={out}", url],
            capture_output=True, text=True, timeout=timeout_s, check=False,
            stdin=subprocess.DEVNULL,
        )  # fmt: skip
        console = [line for line in result.stderr.splitlines() if "CONSOLE" in line]
        if not out.is_file():
            raise RuntimeError(f"Chromium wrote no screenshot of {url}: {result.stderr[-2000:]}")
        return out.read_bytes(), console
    finally:
        shutil.rmtree(profile, ignore_errors=True)
