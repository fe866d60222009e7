"""Shutdown reaches rest (issue #11): SIGTERM and SIGINT take the same path in `nutty serve` - the API
stops taking commands, the robot parks at its exact rest pose while every driver still gets frames,
then the HTTP server (with a graceful-shutdown timeout), the drivers and the Pre-Viz close - and the
process exits within --shutdown-timeout plus a small bound even with zombie clients.

The process tests run real servers (tests/server_process.py); the unit tests drive `Shutdown` and
`ShutdownGate` with fakes. Time bounds are generous: only "exits within shutdown-timeout + 5 s".
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import pytest
import websockets
from fastapi import FastAPI, WebSocket, WebSocketDisconnect
from server_process import free_port, server_process
from starlette.testclient import TestClient

from backend import shutdown
from backend.commands import serve
from backend.engine.embodiment import DofType, load_embodiment

SHUTDOWN_TIMEOUT = 3.0
EXIT_SLACK = 5.0  # the process must be gone within shutdown-timeout + this
GAZE = [0.4, 0.5, 0.3]
REST_TOL = 1e-9


@pytest.fixture(scope="module")
def rest() -> dict[str, float]:
    emb = load_embodiment("nutty_desk")
    return {d.name: float(emb.rest[d.channels.start]) for d in emb.dofs if d.type is DofType.continuous}


def off_rest(doc: dict, rest: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Continuous DoFs of a frame (its to_dict form) not exactly at rest with zero velocity."""
    bad = {}
    for name, r in rest.items():
        v = doc["dofs"][name]
        if abs(v["position"] - r) > REST_TOL or abs(v["velocity"]) > REST_TOL:
            bad[name] = (v["position"], v["velocity"])
    return bad


def last_recorded(path) -> dict:
    lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    assert lines, "the recorder wrote nothing"
    return json.loads(lines[-1])


def raw_websocket(port: int, path: str, rcvbuf: int | None = None) -> socket.socket:
    """A bare TCP socket that completed a WebSocket handshake; the test decides how it misbehaves."""
    s = socket.socket()
    if rcvbuf:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.settimeout(10)
    s.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(
        (
            f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = s.recv(4096)
        assert chunk, "closed during the handshake"
        head += chunk
    assert b" 101 " in head.split(b"\r\n", 1)[0], head[:200]
    return s


def abort(s: socket.socket) -> None:
    """Close with a TCP reset, no WebSocket close frame (a crashed client)."""
    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    s.close()


async def scenario(
    srv,
    rest: dict[str, float],
    sig: int,
    *,
    zombies: bool,
    extra_signals: tuple[int, ...] = (),
    timeout: float = SHUTDOWN_TIMEOUT,
) -> dict:
    """Turn the gaze with a driver on /ws/frames, add misbehaving clients, signal, wait for the exit."""
    frames: list[dict] = []
    moved = asyncio.Event()

    async def driver() -> None:  # a well-behaved driver: reads every frame until the server closes
        async with websockets.connect(f"{srv.ws_url}/ws/frames", max_size=None) as ws:
            try:
                async for raw in ws:
                    doc = json.loads(raw)
                    frames.append(doc)
                    if abs(doc["dofs"]["body_yaw"]["position"] - rest["body_yaw"]) > 0.05:
                        moved.set()
            except websockets.ConnectionClosed:
                pass

    reader = asyncio.create_task(driver())
    await asyncio.to_thread(srv.client.command, "set_gaze", target=GAZE)
    await asyncio.wait_for(moved.wait(), 20)  # body_yaw turned towards the target

    held: list = []
    if zombies:
        stalled = raw_websocket(srv.port, "/ws/frames", rcvbuf=4096)  # stops reading: its sends back up
        held.append(stalled)
        closed = raw_websocket(srv.port, "/ws/frames?decimate=1000")  # waits on its queue forever...
        await asyncio.sleep(0.2)
        abort(closed)  # ...after its client vanished
        telemetry = await websockets.connect(f"{srv.ws_url}/ws/telemetry")
        await telemetry.send(json.dumps({"type": "subscribe", "signals": [], "frames": True, "rate": 0.01}))
        held.append(telemetry)
        await asyncio.sleep(1.0)  # the stalled reader's buffers fill
    srv.signal(sig)
    for extra in extra_signals:
        await asyncio.sleep(0.3)
        srv.signal(extra)
    exited = await asyncio.to_thread(srv.wait_exit, timeout + EXIT_SLACK)
    if not exited:
        srv.kill()
    with contextlib.suppress(TimeoutError, OSError, websockets.WebSocketException):
        await asyncio.wait_for(reader, 10)
    for h in held:
        if isinstance(h, socket.socket):
            h.close()
    return {"exited": exited, "frames": frames}


def run_shutdown(
    tmp_path, rest, sig, *, zombies=True, extra_signals=(), timeout=SHUTDOWN_TIMEOUT, previz=False
) -> tuple[dict, object, object]:
    record = tmp_path / "frames.jsonl"
    args = ["--record", str(record), "--shutdown-timeout", f"{timeout:g}", "--rate", "100"]
    args += ["--previz-port", str(free_port())] if previz else ["--no-previz"]
    with server_process(*args) as srv:
        out = asyncio.run(
            scenario(srv, rest, sig, zombies=zombies, extra_signals=extra_signals, timeout=timeout)
        )
        proc = srv.proc
        output = srv.output
    return out, proc, (record, output)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_parks_the_robot_at_rest_despite_zombie_clients(tmp_path, rest, sig):
    out, proc, (record, output) = run_shutdown(tmp_path, rest, sig)
    # Independent of park(): the signal is handled (no re-raise before the fade), hung clients
    # cannot hold the process, the drivers were closed in order.
    assert out["exited"], f"still running {SHUTDOWN_TIMEOUT + EXIT_SLACK:g} s after the signal:\n{output}"
    assert proc.returncode in (0, 1), output  # not killed by the re-raised signal (-15 / -2)
    assert "taking the robot to rest" in output and "drivers closed" in output, output
    # Depends on EngineSession.park(): the exact rest pose, zero velocity, in the recording ...
    last = last_recorded(record)
    assert off_rest(last, rest) == {}, f"last recorded frame (seq {last['seq']}) is not at rest:\n{output}"
    # ... and as the last frame a /ws/frames driver received before the server closed it.
    assert out["frames"], "the driver got no frames"
    assert off_rest(out["frames"][-1], rest) == {}
    assert proc.returncode == 0, output


@pytest.mark.slow
def test_second_signal_hurries_but_still_reaches_rest(tmp_path, rest):
    out, proc, (record, output) = run_shutdown(
        tmp_path,
        rest,
        signal.SIGINT,
        zombies=True,
        timeout=2.0,
        extra_signals=(signal.SIGINT, signal.SIGTERM),
    )
    assert out["exited"], output
    assert proc.returncode in (0, 1), output
    assert "hurrying" in output and "already stopping" in output, output
    # Depends on EngineSession.park(): hurrying never skips the rest.
    assert off_rest(last_recorded(record), rest) == {}, output
    assert proc.returncode == 0, output


@pytest.mark.slow
def test_sigterm_with_previz_closes_everything(tmp_path, rest):
    pytest.importorskip("viser")
    out, proc, (record, output) = run_shutdown(tmp_path, rest, signal.SIGTERM, zombies=False, previz=True)
    assert out["exited"], output
    assert proc.returncode in (0, 1), output
    assert off_rest(last_recorded(record), rest) == {}, output  # depends on EngineSession.park()


def test_shutdown_timeout_is_checked():
    out = subprocess.run(
        [sys.executable, "-m", "backend.cli", "serve", "--no-previz", "--shutdown-timeout", "0"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2 and "--shutdown-timeout" in out.stderr


# --- Shutdown with fakes -----------------------------------------------------------------------------


class FakeEngine:
    def __init__(self, log):
        self.log = log
        self.sinks = []
        self.last_frame = None
        self.running = True

    def stop(self):
        self.log.append("stop")
        self.running = False

    def close(self):
        self.log.append("close")


class FakeSession:
    def __init__(self, park_seconds=0.05, reached=True, hang=False):
        self.log: list = []
        self.engine = FakeEngine(self.log)
        self.embodiment = load_embodiment("nutty_desk")
        self._park = (park_seconds, reached, hang)
        self.parked_with: list[float] = []

    def park(self, timeout: float = 3.0) -> dict:
        seconds, reached, hang = self._park
        self.parked_with.append(timeout)
        self.log.append("park")
        time.sleep(3600 if hang else seconds)
        return {"reached_rest": reached, "seconds": seconds, "max_error": 0.0 if reached else 0.1}


class FakeServer:
    def __init__(self, session):
        self.session = session
        self.config = SimpleNamespace(timeout_graceful_shutdown=shutdown.HTTP_GRACE)
        self.force_exit = False
        self._exit = False

    @property
    def should_exit(self):
        return self._exit

    @should_exit.setter
    def should_exit(self, value):
        self.session.log.append("server_exit")
        self._exit = value


def test_shutdown_parks_before_the_server_stops_then_closes():
    session = FakeSession()
    sd = shutdown.Shutdown(session, timeout=2.5, watchdog=False)
    sd.before_server_stops(lambda: session.log.append("hook"))
    server = sd.attach(FakeServer(session))
    assert not sd.closing.is_set()
    sd.request("SIGTERM")
    assert sd.parked.wait(5)
    deadline = time.monotonic() + 2
    while not server.should_exit and time.monotonic() < deadline:
        time.sleep(0.01)
    assert sd.closing.is_set() and server.should_exit
    assert session.parked_with == [2.5]
    assert session.log == ["park", "stop", "hook", "server_exit"]  # at rest, clock stopped, then the server
    previz = SimpleNamespace(stopped=False)
    previz.stop = lambda: setattr(previz, "stopped", True)
    assert sd.finish(previz) == 0
    assert session.log[-1] == "close" and previz.stopped
    assert server.config.timeout_graceful_shutdown == shutdown.HTTP_GRACE  # one signal: full grace


def test_second_signal_shortens_the_grace_not_the_park():
    session = FakeSession(park_seconds=0.5)
    sd = shutdown.Shutdown(session, timeout=2.0, watchdog=False)
    server = sd.attach(FakeServer(session))
    sd.request("SIGINT")
    time.sleep(0.1)
    sd.request("SIGINT")
    sd.request("SIGTERM")
    assert sd.hurried and server.config.timeout_graceful_shutdown == shutdown.HURRIED_GRACE
    assert sd.parked.wait(5)
    assert session.log.count("park") == 1 and session.log[:2] == ["park", "stop"]  # parked once, fully
    assert not server.force_exit
    sd.request("SIGINT")  # at rest already, uvicorn waiting for clients: stop waiting
    assert server.force_exit
    assert sd.finish() == 0


def test_signal_before_the_server_exists_stops_it_at_once():
    session = FakeSession()
    sd = shutdown.Shutdown(session, timeout=1.0, watchdog=False)
    sd.request("SIGTERM")
    assert sd.parked.wait(5)
    server = sd.attach(FakeServer(session))
    assert server.should_exit
    assert sd.finish() == 0


def test_server_stopping_by_itself_still_parks():
    session = FakeSession()
    sd = shutdown.Shutdown(session, timeout=1.0, watchdog=False)
    assert sd.finish() == 0  # finish() asks for the park itself
    assert session.log[:2] == ["park", "stop"] and session.log[-1] == "close"


def test_park_that_fails_or_hangs_is_reported_and_bounded(monkeypatch):
    monkeypatch.setattr(serve, "PARK_SLACK", 0.2)
    session = FakeSession(hang=True)
    sd = shutdown.Shutdown(session, timeout=0.3, watchdog=False)
    sd.request("SIGTERM")
    assert sd.parked.wait(5)  # the park hangs for an hour: the shutdown stopped waiting for it
    assert sd.result["reached_rest"] is False and "did not return" in sd.result["error"]
    assert sd.finish() == 1


def test_watchdog_ends_a_hung_shutdown(monkeypatch):
    monkeypatch.setattr(serve, "EXIT_BOUND", 0.3)
    monkeypatch.setattr(serve, "PARK_SLACK", 10.0)
    exited = threading.Event()
    codes = []

    def fake_exit(code):
        codes.append(code)
        exited.set()

    sd = shutdown.Shutdown(FakeSession(hang=True), timeout=0.2, exit=fake_exit)
    sd.request("SIGTERM")
    assert exited.wait(5) and codes == [1]


def test_serve_still_exports_the_shutdown_machinery():
    assert serve.Shutdown is shutdown.Shutdown and serve.ShutdownGate is shutdown.ShutdownGate
    assert serve.park_robot is shutdown.park_robot and serve.rest_and_stop is shutdown.rest_and_stop


def test_park_robot_prefers_session_park():
    session = FakeSession()
    assert shutdown.park_robot(session, 1.5)["reached_rest"] is True
    assert session.parked_with == [1.5]


# --- ShutdownGate ---------------------------------------------------------------------------------------


def gated_app():
    app = FastAPI()

    @app.get("/api/status")
    def status():
        return {"ok": True}

    @app.post("/api/commands")
    def command():
        return {"done": True}

    async def echo(ws: WebSocket):
        await ws.accept()
        try:
            while True:
                await ws.send_json({"echo": await ws.receive_text()})
        except WebSocketDisconnect:
            pass

    app.add_api_websocket_route("/ws/control", echo)
    app.add_api_websocket_route("/ws/telemetry", echo)

    closing = threading.Event()
    return shutdown.ShutdownGate(app, closing), closing


def test_gate_refuses_commands_and_new_websockets_once_closing():
    gate, closing = gated_app()
    with TestClient(gate) as c:
        assert c.post("/api/commands").status_code == 200
        with c.websocket_connect("/ws/control") as ws, c.websocket_connect("/ws/telemetry") as watcher:
            ws.send_text("hi")
            assert ws.receive_json() == {"echo": "hi"}
            closing.set()
            ws.send_text("look left")  # arrives during the park: ends the session, never executed
            with pytest.raises(WebSocketDisconnect) as ended:
                ws.receive_json()
            assert ended.value.code == 1001
            watcher.send_text("subscribe")  # watching the robot park is fine
            assert watcher.receive_json() == {"echo": "subscribe"}
        r = c.post("/api/commands")
        assert r.status_code == 503 and r.json()["detail"]["code"] == "shutting_down"
        assert c.get("/api/status").json() == {"ok": True}  # reads still work
        with pytest.raises(WebSocketDisconnect) as refused, c.websocket_connect("/ws/control"):
            pass
        assert refused.value.code == 1001
