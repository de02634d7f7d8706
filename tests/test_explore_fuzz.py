"""Issue 33's fuzz of the explorer's server over HTTP and its websocket: malformed requests,
garbage bytes, oversized headers and messages, handshakes without a session token, and
messages Bokeh's protocol does not know. After each case the server still runs and answers
its static files within 1 s and a new page (the issue's goal: one session's input never
stalls another; the browser test of a long computation is in test_explore_browser.py). No
browser is needed: the cases are raw sockets and tornado's websocket client (tornado
comes with Bokeh)."""

import asyncio
import json
import socket
import time
import urllib.error
import urllib.request

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from .conftest import explorer_process, server_log

# (one server for the module; a real server process under fuzz, 10 s: .ci/run's long set)
pytestmark = [pytest.mark.xdist_group("explorer-fuzz"), pytest.mark.long]


@pytest.fixture(scope="module")
def server():
    yield from explorer_process()


def _answers(port, proc, page: bool = False) -> None:
    """The server is alive and its event loop free: BokehJS's static file is served within
    1 s; with ``page``, a new session's page too (10 s: each page is a new session whose
    first computation shares the machine's two cores with the fuzz's earlier sessions)."""
    assert proc.poll() is None, "the server stopped"
    t = time.monotonic()
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/static/js/bokeh.min.js", timeout=10) as r:
        assert r.status == 200 and len(r.read()) > 100_000
    assert time.monotonic() - t < 1.0
    if page:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10) as r:
                assert r.status == 200 and b"bokeh" in r.read().lower()
        except OSError as exc:  # (an HTTPError too) the server's own account of it
            raise AssertionError(f"a new session's page: {exc}; the server said:\n{server_log(proc)}") from exc


def _raw(port, data: bytes, read: bool = True) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        try:
            s.sendall(data)
            s.shutdown(socket.SHUT_WR)
            return s.recv(4096) if read else b""
        except OSError:  # the server may close first: that is an answer too
            return b""


@pytest.mark.parametrize("data", [
    b"\x00\xff" * 2048,                                              # not HTTP at all
    b"GET / HTTP/1.1\r\nHost: x\r\n" + b"X-A: " + b"a" * 200_000 + b"\r\n\r\n",  # an oversized header
    b"BREW /pot HTTP/1.1\r\nHost: x\r\n\r\n",                        # an unknown method
    b"GET /../../../../etc/passwd HTTP/1.1\r\nHost: x\r\n\r\n",      # path traversal
    b"GET /static/../../../../etc/passwd HTTP/1.1\r\nHost: x\r\n\r\n",
    b"POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 99999999999\r\n\r\nabc",  # a body that never comes
    b"GET /ws HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\r\n",  # half a handshake
    b"GET /?bokeh-session-id=" + b"%00" * 5000 + b" HTTP/1.1\r\nHost: x\r\n\r\n",
], ids=["binary", "huge-header", "unknown-method", "traversal", "static-traversal", "endless-body", "half-handshake",
        "nul-session-id"])
def test_malformed_http_never_stops_the_server(server, data):
    port, proc = server
    reply = _raw(port, data)
    assert b"root:" not in reply  # nothing of the file system leaks
    _answers(port, proc, page=True)


@settings(max_examples=25)
@given(st.binary(min_size=1, max_size=4096))
def test_random_bytes_never_stop_the_server(server, data):
    port, proc = server
    _raw(port, data, read=False)
    _answers(port, proc)


def test_websocket_garbage_never_stops_the_server(server):
    """The websocket without a session token, with garbage, with an oversized message and
    with well-formed JSON Bokeh does not know: each is refused or dropped by the server."""
    from tornado.httpclient import HTTPRequest
    from tornado.websocket import websocket_connect

    port, proc = server

    async def attempt(message, headers=None):
        try:
            req = HTTPRequest(f"ws://127.0.0.1:{port}/ws", headers=headers or {}, request_timeout=5)
            conn = await asyncio.wait_for(websocket_connect(req), 5)
        except Exception:  # noqa: BLE001 - a refused handshake is the expected answer
            return "refused"
        try:
            await conn.write_message(message, binary=isinstance(message, bytes))
            await asyncio.wait_for(conn.read_message(), 3)
        except Exception:  # noqa: BLE001 - closed or silent: both fine
            pass
        finally:
            conn.close()
        return "connected"

    cases = [("hello", None), (b"\x00" * 1000, None), ("x" * 30_000_000, None),
             (json.dumps({"msgtype": "PATCH-DOC", "content": {"events": [{"kind": "ModelChanged"}] * 1000}}),
              {"Sec-WebSocket-Protocol": "bokeh, not-a-token"}),
             ("{" * 100_000, {"Sec-WebSocket-Protocol": "bokeh, eyJzZXNzaW9uX2lkIjogIngifQ"})]
    for message, headers in cases:
        asyncio.run(attempt(message, headers))
        _answers(port, proc, page=True)
