"""Who may change the robot, against real `nutty serve` processes.

- The default server (127.0.0.1, no token): a cross-origin page cannot run a command (not even with a
  CORS-free `text/plain` POST) nor open a WebSocket; same-origin pages and Origin-less clients (curl,
  Python) can; JSON bodies must be declared `application/json`.
- DNS rebinding: a request naming a foreign Host is refused even from loopback.
- With `--host 0.0.0.0 --token T`: every mutating route and WebSocket needs the token (header or
  `?token=`), and the viser Pre-Viz never listens on a public address: it is on 127.0.0.1 only and
  reached through the API port at /previz/, behind the same token.
"""

from __future__ import annotations

import base64
import json
import os
import socket
from pathlib import Path
from types import SimpleNamespace

import httpx
import pytest
import viser
from server_process import free_port, running_app, running_server_proc
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect as ws_connect

from backend.api import create_app
from backend.commands.serve import builtin_idle
from backend.session import EngineSession

pytestmark = pytest.mark.slow
EVIL = "http://evil.example"
TOKEN = "s3cret-T"
APP_ORIGIN = "http://app.example:5173"
SET_AROUSAL = {"type": "set_input", "name": "arousal", "value": 0.7}


@pytest.fixture(scope="module")
def local(desk):
    """The default server: what `nutty serve` builds on 127.0.0.1 without a token, under a real uvicorn
    (in this process, to keep the suite quick; `guarded` below is a real `nutty serve`)."""
    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    session.engine.start()
    port = free_port()
    try:
        with (
            running_app(create_app(session, frontend_dir=None, host="127.0.0.1", port=port), port=port),
            httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30.0) as http,
        ):
            yield SimpleNamespace(port=port, url=f"http://127.0.0.1:{port}", http=http)
    finally:
        session.engine.close()


@pytest.fixture(scope="module")
def guarded():
    with running_server_proc(
        "--host",
        "0.0.0.0",
        "--token",
        TOKEN,
        "--previz-port",
        "0",
        "--allowed-origin",
        APP_ORIGIN,
        "--sim-servo",
        "0",
    ) as srv:
        srv.http = httpx.Client(base_url=srv.url, timeout=30.0)
        yield srv
        srv.http.close()


def _arousal(srv) -> float:
    return srv.http.get("/api/inputs").json()["values"]["arousal"]


def _reset_arousal(srv, headers=None) -> None:
    r = srv.http.put("/api/inputs/arousal", json={"value": 0.0}, headers=headers or {})
    assert r.status_code == 200, r.text


def _ws_close(url: str, **kw) -> tuple[int, str]:
    """Open a WebSocket expected to be refused: the close code and reason the server sent."""
    with ws_connect(url, open_timeout=30, **kw) as ws, pytest.raises(ConnectionClosed) as closed:
        ws.recv(timeout=30)
    return closed.value.rcvd.code, closed.value.rcvd.reason


def _ws_works(url: str, **kw) -> None:
    with ws_connect(url, open_timeout=30, **kw) as ws:
        ws.send(json.dumps({"id": "probe", "type": "set_emotion", "valence": 0.0, "arousal": 0.0}))
        while True:
            msg = json.loads(ws.recv(timeout=30))
            if msg["type"] != "event":
                break
        assert (msg["type"], msg["id"], msg["status"]) == ("ack", "probe", "completed"), msg


def _raw_ws(port: int, path: str, host: str, origin: str | None = None) -> tuple[bytes, int | None, str]:
    """A WebSocket handshake with any Host header (a rebinding page's name): the status line and
    the close code and reason of the first frame."""
    key = base64.b64encode(os.urandom(16)).decode()
    lines = [
        f"GET {path} HTTP/1.1",
        f"Host: {host}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        f"Sec-WebSocket-Key: {key}",
        "Sec-WebSocket-Version: 13",
    ]
    if origin:
        lines.append(f"Origin: {origin}")
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        data = b""
        while b"\r\n\r\n" not in data:
            data += s.recv(4096)
        head, _, rest = data.partition(b"\r\n\r\n")
        while len(rest) < 2 or len(rest) < 2 + (rest[1] & 0x7F):
            chunk = s.recv(4096)
            if not chunk:
                break
            rest += chunk
    status = head.split(b"\r\n")[0]
    if len(rest) >= 4 and rest[0] == 0x88:
        n = rest[1] & 0x7F
        return status, int.from_bytes(rest[2:4], "big"), rest[4 : 2 + n].decode()
    return status, None, ""


# --- the default server: origins, content types, rebinding ------------------------------------------------------


def test_cross_origin_simple_post_is_refused_and_not_executed(local):
    _reset_arousal(local)
    body = json.dumps(SET_AROUSAL).encode()
    for headers in (
        {"Origin": EVIL, "Content-Type": "text/plain"},
        {"Origin": EVIL, "Content-Type": "application/x-www-form-urlencoded"},
        {"Origin": EVIL, "Content-Type": "application/json"},
        {"Origin": "null", "Content-Type": "text/plain"},
        {"Origin": f"http://127.0.0.1:{local.port + 1}", "Content-Type": "application/json"},
    ):
        r = local.http.post("/api/commands", content=body, headers=headers)
        assert r.status_code == 403 and r.json()["detail"]["code"] == "forbidden_origin", (headers, r.text)
    for method, path in (
        ("DELETE", "/api/commands/x"),
        ("DELETE", "/api/programs/interactive"),
        ("PUT", "/api/inputs/arousal"),
        ("PATCH", "/api/program/nodes/breathe/params"),
    ):
        assert local.http.request(method, path, headers={"Origin": EVIL}).status_code == 403
    assert _arousal(local) == 0.0  # nothing ran
    # Reads too: another site's script may not read the robot's state (a navigation sends no Origin).
    r = local.http.get("/api/status", headers={"Origin": EVIL})
    assert r.status_code == 403 and r.json()["detail"]["code"] == "forbidden_origin"
    assert local.http.get("/api/status").status_code == 200
    assert (
        local.http.get("/api/status", headers={"Origin": f"http://127.0.0.1:{local.port}"}).status_code == 200
    )


def test_json_routes_take_only_declared_json(local):
    body = json.dumps(SET_AROUSAL).encode()
    for ctype in ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x", None):
        headers = {"Content-Type": ctype} if ctype else {}
        r = local.http.post("/api/commands", content=body, headers=headers)
        assert r.status_code == 415 and r.json()["detail"]["code"] == "unsupported_media_type", (
            ctype,
            r.text,
        )
        r = local.http.put("/api/inputs/arousal", content=b'{"value": 0.9}', headers=headers)
        assert r.status_code == 415
    assert _arousal(local) == 0.0
    r = local.http.post(
        "/api/commands", content=body, headers={"Content-Type": "application/json; charset=utf-8"}
    )
    assert r.status_code == 200 and _arousal(local) == 0.7
    _reset_arousal(local)


def test_same_origin_and_origin_less_requests_are_accepted(local):
    for origin in (
        f"http://127.0.0.1:{local.port}",
        f"http://localhost:{local.port}",
        f"http://[::1]:{local.port}",
        None,
    ):
        _reset_arousal(local)
        headers = {"Origin": origin} if origin else {}
        r = local.http.post("/api/commands", json=SET_AROUSAL, headers=headers)
        assert r.status_code == 200, (origin, r.text)
        assert _arousal(local) == 0.7
    _reset_arousal(local)


def test_foreign_origin_websockets_are_closed_with_4403(local):
    for path in ("/ws/control", "/ws/telemetry", "/ws/frames"):
        code, reason = _ws_close(f"ws://127.0.0.1:{local.port}{path}", origin=EVIL)
        assert code == 4403 and "origin" in reason.lower(), (path, code, reason)
    _ws_works(f"ws://127.0.0.1:{local.port}/ws/control", origin=f"http://127.0.0.1:{local.port}")
    _ws_works(f"ws://127.0.0.1:{local.port}/ws/control", origin=f"http://localhost:{local.port}")
    _ws_works(f"ws://127.0.0.1:{local.port}/ws/control")  # no Origin: not a browser


def test_dns_rebinding_hosts_are_refused(local):
    _reset_arousal(local)
    port = local.port
    for host, origin in (
        (f"evil.example:{port}", f"http://evil.example:{port}"),
        (f"evil.example:{port}", None),
        (f"127.0.0.1:{port + 1}", None),
        ("localhost", None),
        (f"10.0.0.7:{port}", None),
    ):
        headers = {"Host": host, **({"Origin": origin} if origin else {})}
        r = local.http.post("/api/commands", json=SET_AROUSAL, headers=headers)
        assert r.status_code == 403 and r.json()["detail"]["code"] == "forbidden_host", (host, r.text)
        for path in ("/api/status", "/api/program", "/"):  # a rebinding page reads nothing either
            r = local.http.get(path, headers=headers)
            assert r.status_code == 403 and r.json()["detail"]["code"] == "forbidden_host", (
                host,
                path,
                r.text,
            )
        status, code, reason = _raw_ws(port, "/ws/control", host, origin)
        assert b" 101 " in status and code == 4403 and "host" in reason.lower(), (host, status, code, reason)
    assert _arousal(local) == 0.0
    r = local.http.post("/api/commands", json=SET_AROUSAL, headers={"Host": f"localhost:{port}"})
    assert r.status_code == 200
    status, code, _ = _raw_ws(port, "/ws/frames", f"localhost:{port}", f"http://localhost:{port}")
    assert b" 101 " in status and code is None  # accepted: the first frame is a frame, not a close
    _reset_arousal(local)


# --- --host 0.0.0.0 --token T: the token, the proxied Pre-Viz ---------------------------------------------------


def test_the_token_is_needed_in_one_of_its_forms(guarded):
    auth = {"Authorization": f"Bearer {TOKEN}"}
    _reset_arousal(guarded, auth)
    for headers, params in (
        ({}, {}),
        ({"Authorization": "Bearer wrong"}, {}),
        ({}, {"token": "wrong"}),
        ({"Authorization": TOKEN}, {}),
    ):
        r = guarded.http.post("/api/commands", json=SET_AROUSAL, headers=headers, params=params)
        assert r.status_code == 401 and r.json()["detail"]["code"] == "unauthorized", (headers, params)
    assert _arousal(guarded) == 0.0
    assert guarded.http.post("/api/commands", json=SET_AROUSAL, headers=auth).status_code == 200
    _reset_arousal(guarded, auth)
    assert guarded.http.post("/api/commands", json=SET_AROUSAL, params={"token": TOKEN}).status_code == 200
    _reset_arousal(guarded, auth)
    # the token does not replace the origin check, nor the host check
    r = guarded.http.post("/api/commands", json=SET_AROUSAL, headers={**auth, "Origin": EVIL})
    assert r.status_code == 403
    r = guarded.http.post(
        "/api/commands", json=SET_AROUSAL, headers={**auth, "Host": f"evil.example:{guarded.port}"}
    )
    assert r.status_code == 403
    # bound to every address: a page loaded from one of the machine's IP addresses is same-origin
    lan = f"10.1.2.3:{guarded.port}"
    r = guarded.http.post(
        "/api/commands", json=SET_AROUSAL, headers={**auth, "Host": lan, "Origin": f"http://{lan}"}
    )
    assert r.status_code == 200
    # --allowed-origin: a page from another origin, with CORS
    r = guarded.http.post("/api/commands", json=SET_AROUSAL, headers={**auth, "Origin": APP_ORIGIN})
    assert r.status_code == 200 and r.headers["access-control-allow-origin"] == APP_ORIGIN
    _reset_arousal(guarded, auth)
    # WebSockets: ?token= (browsers) or the header (other clients)
    ws = f"ws://127.0.0.1:{guarded.port}/ws/control"
    code, reason = _ws_close(ws)
    assert code == 4401 and "token" in reason
    assert _ws_close(ws + "?token=wrong")[0] == 4401
    _ws_works(ws + f"?token={TOKEN}")
    _ws_works(ws, additional_headers=auth)
    assert _ws_close(ws + f"?token={TOKEN}", origin=EVIL)[0] == 4403


def _family(pid: int) -> list[int]:
    """`pid` and its descendants (the Pre-Viz runs in a child process of the server)."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        for task in Path(f"/proc/{p}/task").iterdir():
            children = task / "children"
            if children.exists():
                todo += [int(c) for c in children.read_text().split()]
    return out


def _listening(pid: int) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket process `pid` or one of its children listens on, from /proc."""
    inodes = set()
    for member in _family(pid):
        for fd in Path(f"/proc/{member}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
    found = []
    for table, width in (("/proc/net/tcp", 4), ("/proc/net/tcp6", 16)):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] != "0A" or fields[9] not in inodes:  # 0A: LISTEN
                continue
            addr_hex, port_hex = fields[1].split(":")
            raw = bytes.fromhex(addr_hex)
            raw = b"".join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))  # host-order 32-bit words
            addr = socket.inet_ntop(socket.AF_INET if width == 4 else socket.AF_INET6, raw)
            found.append((addr, int(port_hex, 16)))
    return found


def test_previz_listens_on_loopback_only_and_is_proxied_behind_the_token(guarded):
    info = guarded.http.get("/api/previz").json()
    assert info["url"] == f"{guarded.url}/previz/" and info["token_required"] is True
    assert info["direct"] is None  # with a token there is no way in but the proxy: none is advertised
    listening = _listening(guarded.proc.pid)
    assert ("0.0.0.0", guarded.port) in listening
    public = [(a, p) for a, p in listening if a not in ("127.0.0.1", "::1")]
    assert public == [("0.0.0.0", guarded.port)], listening  # only the API, which checks the token
    (direct_port,) = [p for a, p in listening if a == "127.0.0.1"]  # viser's own port, loopback only

    # the page: token needed; with it, a cookie for the page's WebSocket
    assert guarded.http.get("/previz/").status_code == 401
    page = guarded.http.get("/previz/", params={"token": TOKEN})
    assert page.status_code == 200 and b"<html" in page.content[:500].lower()
    cookie = page.cookies.get("nutty_previz")
    assert cookie and TOKEN not in cookie

    # the WebSocket viser's page opens (its own URL without the query): token or cookie needed
    sub = [f"viser-v{viser.__version__}"]
    ws = f"ws://127.0.0.1:{guarded.port}/previz"
    assert _ws_close(ws, subprotocols=sub)[0] == 4401
    assert _ws_close(ws + f"?token={TOKEN}", subprotocols=sub, origin=EVIL)[0] == 4403
    for url, headers in ((ws, {"Cookie": f"nutty_previz={cookie}"}), (ws + f"?token={TOKEN}", {})):
        with ws_connect(
            url, subprotocols=sub, additional_headers=headers, max_size=None, open_timeout=30
        ) as conn:
            assert conn.subprotocol == sub[0]
            assert isinstance(conn.recv(timeout=30), bytes)  # viser's scene, relayed

    # viser's own port (loopback) serves nobody but the proxy when the server has a token: not a page
    # from another origin, and not a local client with no Origin at all (it would move the gaze gizmo)
    code, _ = _ws_close(f"ws://127.0.0.1:{direct_port}", subprotocols=sub, origin=EVIL, max_size=None)
    assert code == 4403
    code, reason = _ws_close(f"ws://127.0.0.1:{direct_port}", subprotocols=sub, max_size=None)
    assert code == 4403 and "/previz/" in reason
