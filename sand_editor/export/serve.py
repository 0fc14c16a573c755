"""``sand-editor serve DIR``: an exported web page (``export --format web``) on localhost.

WebXR runs only in a secure context: HTTPS, or ``localhost``. On this machine open the printed
address; on a Quest connected by USB, ``adb reverse tcp:PORT tcp:PORT`` makes the headset's
``localhost:PORT`` this server, so its browser can open the page and enter VR.
"""

from __future__ import annotations

import functools
import sys
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from sand_editor.export.web import SCENE_FILE
from sand_editor.untrusted import printable

MIN_PORT, MAX_PORT = 1, 65535
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".json": "application/json",
    ".bin": "application/octet-stream",
}


class _Handler(SimpleHTTPRequestHandler):
    extensions_map = {**SimpleHTTPRequestHandler.extensions_map, **_TYPES}

    def send_head(self):
        # A path the file system cannot take (an encoded NUL, an over-long name) is not found:
        # answered, not a traceback and a dropped connection.
        try:
            return super().send_head()
        except (ValueError, OSError):
            self.send_error(404, "not found")
            return None

    def list_directory(self, path):  # noqa: ARG002 (the base class's signature)
        self.send_error(404, "no listings")
        return None

    def log_message(self, format, *args):  # noqa: A002 (the base class's name)
        pass


def check_site(folder: Path) -> None:
    """Refuse a folder that is not a complete web export, naming what is missing."""
    if not folder.is_dir():
        raise ValueError(f"{folder}: no such folder; give the folder export --format web wrote")
    if not (folder / SCENE_FILE).is_file():
        raise ValueError(
            f"{folder}: has no {SCENE_FILE}, so it is not a complete web export; "
            "write one with: sand-editor export PRESET --format web --out FOLDER"
        )


def make_server(folder: Path, host: str = "127.0.0.1", port: int = 8000) -> ThreadingHTTPServer:
    """A server of ``folder``'s files (port 0: any free one), not yet serving."""
    check_site(folder)
    if not MIN_PORT - 1 <= port <= MAX_PORT:
        raise ValueError(f"--port {port}: allowed {MIN_PORT} to {MAX_PORT}")
    handler = functools.partial(_Handler, directory=str(folder.resolve()))
    server = ThreadingHTTPServer((host, port), handler)
    server.daemon_threads = True
    return server


def serve(folder: Path, host: str = "127.0.0.1", port: int = 8000) -> int:
    """Serve until Ctrl+C; prints the address to open."""
    if port == 0:
        raise ValueError(f"--port {port}: allowed {MIN_PORT} to {MAX_PORT}")
    server = make_server(folder, host, port)
    shown = "localhost" if host in ("127.0.0.1", "localhost") else host
    print(
        f"serving {printable(str(folder))} at http://{shown}:{server.server_address[1]}/ "
        f"(Ctrl+C stops); a Quest on USB: adb reverse tcp:{port} tcp:{port}, then open "
        f"http://localhost:{port}/ in its browser",
        flush=True,
    )
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("stopped", file=sys.stderr)
    finally:
        server.server_close()
    return 0
