"""HTTP side of the viewer (standard library only): the page, binary frames by long poll, goals by POST.

GET /frame?after=V&<layer>=<version>... answers as soon as the scene is newer than V
(or after a second, so the page notices a dead link), never faster than ``rate``
frames a second; costmaps and the robot body are only sent when the page's copy is
stale. POST /goal with {"x", "y", "yaw"} (fixed frame, radians) sets a navigation goal (RViz's 2D Nav
Goal), POST /initialpose the same way the localizer's pose (2D Pose Estimate).

Either moves the robot, so it is taken only from the viewer's own page: the Host header must
name this server (a foreign name is DNS rebinding), a browser's Origin must be that same
server (anything else is a cross-site request), and the body must be application/json, which
an HTML form cannot send.
"""

from __future__ import annotations

import json
import math
import re
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Callable
from urllib.parse import parse_qs, urlsplit

from simplebot_navigation.viewer.scene import Lookup, Scene
from simplebot_navigation.web_host import is_own_host, machine_names

_DIGITS = re.compile(r"[0-9]+")

STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
          "/index.html": ("index.html", "text/html; charset=utf-8"),
          "/frames.js": ("frames.js", "text/javascript; charset=utf-8"),
          "/viewer.js": ("viewer.js", "text/javascript; charset=utf-8"),
          "/viewer.css": ("viewer.css", "text/css; charset=utf-8")}
LONG_POLL_S = 1.0
MAX_BODY = 4096
#: a client that stops sending mid-request frees its thread after this long
REQUEST_TIMEOUT_S = 10.0


class _HTTPServer(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True


class ViewerServer:
    def __init__(self, scene: Scene, lookup: Lookup, on_goal: Callable[[float, float, float], object],
                 host: str = "127.0.0.1", port: int = 8765, rate: float = 20.0, base_frame: str = "base_link",
                 on_initial_pose: Callable[[float, float, float], object] | None = None):
        self.scene = scene
        self.lookup = lookup
        #: POST path -> what takes the pose
        self.pose_targets = {"/goal": on_goal}
        if on_initial_pose is not None:
            self.pose_targets["/initialpose"] = on_initial_pose
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
        bound = self.httpd.server_address[0]
        self._machine_names = machine_names(bound)

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

    def host_refusal(self, authority: str | None) -> str | None:
        """Why a request with this Host header is refused, or None."""
        bound, port = self.httpd.server_address[:2]
        if authority is None:
            return f"refused, the request has no Host header (this viewer is {bound}:{port})"
        if not is_own_host(authority, bound, port, self._machine_names):
            return f"refused, Host {authority!r} is not this viewer ({bound}:{port}); open {self.url}"
        return None

    def take_pose(self, body: bytes, path: str = "/goal") -> dict:
        """Parse a pose and hand it to the target of ``path``; ValueError names what is wrong with the request."""
        what = path.lstrip("/")
        try:
            data = json.loads(body)
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            raise ValueError(f"{what}: body is not JSON: {err}") from err
        if not isinstance(data, dict):
            raise ValueError(f"{what}: body must be a JSON object with x, y, yaw")
        values = []
        for key in ("x", "y", "yaw"):
            value = data.get(key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"{what}: {key!r} must be a finite number, got {value!r}")
            values.append(float(value))
        self.pose_targets[path](*values)
        return dict(zip(("x", "y", "yaw"), values))

    def _handler_class(self):
        return type("Handler", (_RequestHandler,), {"viewer": self, "timeout": REQUEST_TIMEOUT_S})


class _RequestHandler(BaseHTTPRequestHandler):
    """One viewer request; ``viewer`` is the ViewerServer it answers for and ``timeout`` the socket's, both set by
    ViewerServer._handler_class when the server is made."""
    viewer: "ViewerServer"
    protocol_version = "HTTP/1.1"

    def log_message(self, *args) -> None:  # the console belongs to the navigation nodes
        pass

    def _send(self, status: int, body: bytes, kind: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        if status >= 400:  # the request's body may be unread: it must not be taken for the next request
            self.send_header("Connection", "close")
            self.close_connection = True
        self.end_headers()
        self.wfile.write(body)

    def _refuse(self, status: int, message: str) -> None:
        self._send(status, message.encode(), "text/plain; charset=utf-8")

    def _host_ok(self, prefix: str = "") -> bool:
        refusal = self.viewer.host_refusal(self.headers.get("Host"))
        if refusal:
            self._refuse(HTTPStatus.FORBIDDEN, prefix + refusal)
        return refusal is None

    def do_GET(self) -> None:  # noqa: N802 - http.server's name
        if not self._host_ok():
            return
        url = urlsplit(self.path)
        if url.path == "/frame":
            query = {k: v[-1] for k, v in parse_qs(url.query).items()}
            try:
                after = int(query.pop("after", "-1"))
                known = {k: int(v) for k, v in query.items()}
            except ValueError:
                self._refuse(HTTPStatus.BAD_REQUEST, "frame: versions must be integers")
                return
            self._send(HTTPStatus.OK, self.viewer.frame(after, known), "application/octet-stream")
        elif url.path in self.viewer._static:
            self._send(HTTPStatus.OK, *self.viewer._static[url.path])
        else:
            self._refuse(HTTPStatus.NOT_FOUND, f"no such page: {url.path}")

    def do_POST(self) -> None:  # noqa: N802
        path = urlsplit(self.path).path
        if path not in self.viewer.pose_targets:
            self._refuse(HTTPStatus.NOT_FOUND, f"POST only to {' and '.join(self.viewer.pose_targets)}")
            return
        what = path.lstrip("/")
        if not self._host_ok(f"{what}: "):
            return
        origin = self.headers.get("Origin")
        if origin is not None and origin.strip().lower() != f"http://{self.headers['Host'].strip().lower()}":
            self._refuse(HTTPStatus.FORBIDDEN,
                         f"{what}: refused, Origin {origin!r} is not this viewer (a cross-site request)")
            return
        kind = self.headers.get("Content-Type", "")
        if kind.partition(";")[0].strip().lower() != "application/json":
            self._refuse(HTTPStatus.FORBIDDEN,
                         f"{what}: refused, Content-Type must be application/json, got {kind!r}")
            return
        body = self._read_body(what)
        if body is None:
            return
        try:
            sent = self.viewer.take_pose(body, path)
        except ValueError as err:
            self._refuse(HTTPStatus.BAD_REQUEST, str(err))
            return
        self._send(HTTPStatus.OK, json.dumps(sent).encode(), "application/json")

    def _read_body(self, what: str) -> bytes | None:
        """The body as Content-Length announces it, or None after answering what was wrong."""
        declared = self.headers.get("Content-Length")
        if declared is None:
            self._refuse(HTTPStatus.LENGTH_REQUIRED, f"{what}: Content-Length is required")
            return None
        if not _DIGITS.fullmatch(declared.strip()):
            self._refuse(HTTPStatus.BAD_REQUEST, f"{what}: Content-Length {declared!r} is not a number of bytes")
            return None
        length = int(declared)
        if length == 0:
            self._refuse(HTTPStatus.BAD_REQUEST, f"{what}: the body is empty")
            return None
        if length > MAX_BODY:
            self._refuse(HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
                         f"{what}: a body of {length} bytes is too long (at most {MAX_BODY})")
            return None
        body = b""
        try:
            while len(body) < length:
                chunk = self.rfile.read1(length - len(body))
                if not chunk:
                    break
                body += chunk
        except TimeoutError:
            pass
        if len(body) < length:
            self._refuse(HTTPStatus.BAD_REQUEST, f"{what}: the body ended after {len(body)} of {length} bytes")
            return None
        return body
