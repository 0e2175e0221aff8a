"""The viewer's HTTP server: the page, three.js from its pinned npm install, and the object
as one glTF built by the project's writer (any format the project reads can be viewed)."""

from __future__ import annotations

import json
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from ..errors import UnavailableError

WEB = Path(__file__).resolve().parent / "web"
THREE = WEB / "node_modules" / "three"
INSTALL_HINT = f"install it with: cd {WEB} && npm ci"
PAGE_FILES = {"/": "index.html", "/index.html": "index.html", "/viewer.js": "viewer.js",
              "/viewer.css": "viewer.css"}
CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
                 ".css": "text/css; charset=utf-8", ".json": "application/json"}
GLB_TYPE = "model/gltf-binary"
MAX_STATE_BYTES = 1 << 22


def three_available() -> None:
    """Raise UnavailableError, saying how to install it, when three.js is not in place."""
    if not (THREE / "build" / "three.module.js").is_file():
        raise UnavailableError(f"the viewer's three.js is not installed; {INSTALL_HINT}")


class ViewerServer(ThreadingHTTPServer):
    """Serves one object's glTF (``glb``: its bytes) with the page; keeps the last state the
    page reported (``states``, for headless runs)."""

    daemon_threads = True

    def __init__(self, glb: bytes, host: str = "127.0.0.1", port: int = 0) -> None:
        three_available()
        self.glb = glb
        self.states: list[dict] = []
        self.reported = threading.Event()
        super().__init__((host, port), _Handler)

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{host}:{port}/"


class _Handler(BaseHTTPRequestHandler):
    server: ViewerServer

    def log_message(self, format, *args) -> None:  # noqa: A002 (the base class's name)
        pass  # quiet: the command prints the address, not every request

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        path = self.path.split("?", 1)[0]
        if path == "/model.glb":
            return self._send(self.server.glb, GLB_TYPE)
        if path in PAGE_FILES:
            file = WEB / PAGE_FILES[path]
        elif path.startswith("/three/"):
            file = (THREE / path[len("/three/"):]).resolve()
            if THREE.resolve() not in file.parents:  # nothing outside three.js's folder
                return self.send_error(HTTPStatus.NOT_FOUND)
        else:
            return self.send_error(HTTPStatus.NOT_FOUND)
        if not file.is_file():
            return self.send_error(HTTPStatus.NOT_FOUND)
        self._send(file.read_bytes(), CONTENT_TYPES.get(file.suffix, "application/octet-stream"))

    def do_POST(self) -> None:  # noqa: N802
        if self.path.split("?", 1)[0] != "/state":
            return self.send_error(HTTPStatus.NOT_FOUND)
        length = int(self.headers.get("Content-Length", 0))
        if length > MAX_STATE_BYTES:
            return self.send_error(HTTPStatus.REQUEST_ENTITY_TOO_LARGE)
        try:
            self.server.states.append(json.loads(self.rfile.read(length)))
        except json.JSONDecodeError:
            return self.send_error(HTTPStatus.BAD_REQUEST)
        self.server.reported.set()
        self._send(b"{}", "application/json")

    def _send(self, body: bytes, content_type: str) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)


def model_glb(path: str | Path) -> bytes:
    """The glTF the page shows: any file the project reads, written by our glTF writer (its
    extras carry the joints the sliders need)."""
    from ..formats import load
    from ..formats.gltf.write import build

    return build(load(path))


def serve(path: str | Path, host: str = "127.0.0.1", port: int = 8000,
          open_browser: bool = True) -> None:
    """Serve ``path``'s page until interrupted (Ctrl-C)."""
    server = ViewerServer(model_glb(path), host, port)
    print(f"real2code view: {path} at {server.url}  (Ctrl-C to stop)", flush=True)
    if open_browser:
        import webbrowser

        webbrowser.open(server.url)
    try:
        server.serve_forever()
    finally:
        server.server_close()
