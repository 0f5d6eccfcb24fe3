"""Hostile HTTP requests to the viewer: cross-site goals are refused, malformed requests get an answer."""

import http.client
import json
import socket

import pytest

from simplebot_navigation.viewer import server as viewer_server
from simplebot_navigation.viewer.scene import Scene
from simplebot_navigation.viewer.server import ViewerServer
from simplebot_navigation.web_host import is_own_host

GOAL = b'{"x": 1.0, "y": 2.0, "yaw": 0.5}'


@pytest.fixture(scope="module")
def running():
    """A viewer on a free loopback port; `goals` records what it would publish."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(viewer_server, "REQUEST_TIMEOUT_S", 0.5)
        goals = []
        server = ViewerServer(Scene(), lambda frame, stamp: None, lambda *goal: goals.append(goal), port=0)
    server.goals = goals
    server.port = server.httpd.server_address[1]
    server.start()
    yield server
    server.stop()


@pytest.fixture
def viewer(running):
    running.goals.clear()
    return running


def raw_request(port: int, head: str, body: bytes = b"") -> tuple[int, str]:
    """Send bytes exactly as given (no client-side header fixing); the status and body of the answer."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
        sock.sendall(head.replace("\n", "\r\n").encode() + b"\r\n" + body)
        response = http.client.HTTPResponse(sock)
        response.begin()
        return response.status, response.read().decode()


def post(port: int, headers: dict, body: bytes = GOAL) -> tuple[int, str]:
    head = "POST /goal HTTP/1.1\n" + "".join(f"{k}: {v}\n" for k, v in headers.items())
    return raw_request(port, head, body)


def own(port: int, **extra) -> dict:
    """The headers the viewer's own page sends."""
    return {"Host": f"127.0.0.1:{port}", "Origin": f"http://127.0.0.1:{port}", "Content-Type": "application/json",
            "Content-Length": str(len(GOAL)), **extra}


@pytest.mark.parametrize("host", ["127.0.0.1", "localhost", "LocalHost", "[::1]"])
def test_the_own_page_sets_goals_under_any_loopback_name(viewer, host):
    authority = f"{host}:{viewer.port}"
    status, body = post(viewer.port, own(viewer.port, Host=authority, Origin=f"http://{authority}",
                                         **{"Content-Type": "application/json; charset=utf-8"}))
    assert (status, json.loads(body)) == (200, {"x": 1.0, "y": 2.0, "yaw": 0.5})
    assert viewer.goals == [(1.0, 2.0, 0.5)]


def test_a_client_without_origin_still_sets_goals(viewer):
    headers = own(viewer.port)
    del headers["Origin"]
    assert post(viewer.port, headers)[0] == 200 and len(viewer.goals) == 1


@pytest.mark.parametrize("change, message", [
    ({"Content-Type": "text/plain"}, "goal: refused, Content-Type must be application/json, got 'text/plain'"),
    ({"Content-Type": "application/x-www-form-urlencoded"}, "goal: refused, Content-Type must be application/json"),
    ({"Origin": "http://evil.example"}, "goal: refused, Origin 'http://evil.example' is not this viewer"),
    ({"Origin": "null"}, "goal: refused, Origin 'null' is not this viewer"),
    ({"Host": "evil.example:{port}", "Origin": "http://evil.example:{port}"},
     "refused, Host 'evil.example:{port}' is not this viewer (127.0.0.1:{port})"),
    ({"Host": "127.0.0.1:1", "Origin": "http://127.0.0.1:1"}, "refused, Host '127.0.0.1:1' is not this viewer"),
])
def test_cross_site_goals_are_refused(viewer, change, message):
    headers = own(viewer.port, **{k: v.format(port=viewer.port) for k, v in change.items()})
    status, body = post(viewer.port, headers)
    assert status == 403 and message.format(port=viewer.port) in body
    assert viewer.goals == []


def test_a_rebound_host_cannot_read_frames_either(viewer):
    status, body = raw_request(viewer.port, f"GET /frame?after=-1 HTTP/1.1\nHost: evil.example:{viewer.port}\n")
    assert status == 403 and "Host 'evil.example" in body


def test_a_missing_host_is_refused(viewer):
    assert raw_request(viewer.port, "GET / HTTP/1.0\n")[0] == 403


@pytest.mark.parametrize("length, body, status, message", [
    ("abc", GOAL, 400, "goal: Content-Length 'abc' is not a number of bytes"),
    ("-5", GOAL, 400, "goal: Content-Length '-5' is not a number of bytes"),
    ("0", b"", 400, "goal: the body is empty"),
    ("99999999999999999999", GOAL, 413, "goal: a body of 99999999999999999999 bytes is too long (at most 4096)"),
    ("5000", GOAL, 413, "goal: a body of 5000 bytes is too long (at most 4096)"),
    (None, GOAL, 411, "goal: Content-Length is required"),
    ("100", GOAL, 400, "goal: the body ended after 32 of 100 bytes"),
])
def test_malformed_lengths_get_an_answer(viewer, length, body, status, message):
    headers = own(viewer.port, **{"Content-Length": length})
    if length is None:
        del headers["Content-Length"]
    assert post(viewer.port, headers, body) == (status, message)
    assert viewer.goals == []
    assert post(viewer.port, own(viewer.port))[0] == 200     # and the viewer still serves


@pytest.mark.parametrize("host, bound, expected", [
    ("192.168.1.7:8765", "0.0.0.0", True),        # every interface: any address of this machine
    ("robot-pc:8765", "0.0.0.0", True),           # or its name
    ("localhost:8765", "0.0.0.0", True),
    ("evil.example:8765", "0.0.0.0", False),      # but not a name that resolves elsewhere
    ("192.168.1.7:8765", "192.168.1.7", True),
    ("192.168.1.8:8765", "192.168.1.7", False),
    ("localhost:8765", "192.168.1.7", False),     # a loopback name does not reach that address
    ("robot-pc:8765", "192.168.1.7", True),
    ("192.168.1.7", "0.0.0.0", False),            # port 80 implied
    ("192.168.1.7:80x", "0.0.0.0", False),
])
def test_which_hosts_are_this_viewer(host, bound, expected):
    assert is_own_host(host, bound, 8765, frozenset({"robot-pc"})) is expected
