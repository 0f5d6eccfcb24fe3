"""HTTP side of the viewer (standard library only): the page, binary frames by long poll, goals by POST.

GET /frame?after=V&<layer>=<version>... answers as soon as the scene is newer than V
(or after a second, so the page notices a dead link), never faster than ``rate``
frames a second; costmaps and the robot body are only sent when the page's copy is
stale. POST /goal with {"x", "y", "yaw"} (fixed frame, radians) sets a navigation goal.
"""

from __future__ import annotations

import json
import math
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Callable
from urllib.parse import parse_qs, urlsplit

from simplebot_navigation.viewer.scene import Lookup, Scene

STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
          "/index.html": ("index.html", "text/html; charset=utf-8"),
          "/viewer.js": ("viewer.js", "text/javascript; charset=utf-8"),
          "/viewer.css": ("viewer.css", "text/css; charset=utf-8")}
LONG_POLL_S = 1.0
MAX_BODY = 4096


class _HTTPServer(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True


class ViewerServer:
    def __init__(self, scene: Scene, lookup: Lookup, on_goal: Callable[[float, float, float], object],
                 host: str = "127.0.0.1", port: int = 8765, rate: float = 20.0, base_frame: str = "base_link"):
        self.scene = scene
        self.lookup = lookup
        self.on_goal = on_goal
        self.period_s = 1.0 / rate
        self.base_frame = base_frame
        self._last_frame = 0.0
        #: monotonic time of the last frame request: tells the node whether a page is open
        self.last_request = -math.inf
        self._throttle = threading.Lock()
        self._static = {path: (resources.files(__package__).joinpath("static", name).read_bytes(), kind)
                        for path, (name, kind) in STATIC.items()}
        self.httpd = _HTTPServer((host, port), self._handler_class())
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"http://{host}:{port}/"

    def start(self) -> None:
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="viewer-http", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        if self._thread is not None:
            self.httpd.shutdown()
            self._thread.join(timeout=2.0)
            self._thread = None
        self.httpd.server_close()

    def frame(self, after: int, known: dict[str, int]) -> bytes:
        self.last_request = time.monotonic()
        self.scene.wait_newer(after, LONG_POLL_S)
        with self._throttle:  # one encoding per period, whatever the number of pages
            wait = self._last_frame + self.period_s - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            self._last_frame = time.monotonic()
            return self.scene.encode(self.lookup, known, self.base_frame)

    def goal(self, body: bytes) -> dict:
        """Parse and publish a goal; ValueError names what is wrong with the request."""
        try:
            data = json.loads(body)
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            raise ValueError(f"goal: body is not JSON: {err}") from err
        if not isinstance(data, dict):
            raise ValueError("goal: body must be a JSON object with x, y, yaw")
        values = []
        for key in ("x", "y", "yaw"):
            value = data.get(key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"goal: {key!r} must be a finite number, got {value!r}")
            values.append(float(value))
        self.on_goal(*values)
        return dict(zip(("x", "y", "yaw"), values))

    def _handler_class(self):
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args) -> None:  # the console belongs to the navigation nodes
                pass

            def _send(self, status: int, body: bytes, kind: str) -> None:
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def do_GET(self) -> None:  # noqa: N802 - http.server's name
                url = urlsplit(self.path)
                if url.path == "/frame":
                    query = {k: v[-1] for k, v in parse_qs(url.query).items()}
                    try:
                        after = int(query.pop("after", "-1"))
                        known = {k: int(v) for k, v in query.items()}
                    except ValueError:
                        self._send(HTTPStatus.BAD_REQUEST, b"frame: versions must be integers", "text/plain")
                        return
                    self._send(HTTPStatus.OK, server.frame(after, known), "application/octet-stream")
                elif url.path in server._static:
                    self._send(HTTPStatus.OK, *server._static[url.path])
                else:
                    self._send(HTTPStatus.NOT_FOUND, f"no such page: {url.path}".encode(), "text/plain")

            def do_POST(self) -> None:  # noqa: N802
                if urlsplit(self.path).path != "/goal":
                    self._send(HTTPStatus.NOT_FOUND, b"POST only to /goal", "text/plain")
                    return
                length = int(self.headers.get("Content-Length") or 0)
                if not 0 < length <= MAX_BODY:
                    self._send(HTTPStatus.BAD_REQUEST, b"goal: body missing or too long", "text/plain")
                    return
                try:
                    sent = server.goal(self.rfile.read(length))
                except ValueError as err:
                    self._send(HTTPStatus.BAD_REQUEST, str(err).encode(), "text/plain")
                    return
                self._send(HTTPStatus.OK, json.dumps(sent).encode(), "application/json")

        return Handler
