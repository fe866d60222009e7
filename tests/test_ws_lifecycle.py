"""WebSocket handlers notice their clients leaving and the server stopping: no thread, sink or client
count outlives its client, and a silent client (a /ws/frames reader with no frames coming, a 0.001 Hz
telemetry subscriber) never holds a graceful shutdown."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path

import pytest
import websockets
from server_process import running_app, running_server_proc
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect as ws_connect

from backend.api import create_app
from backend.commands.serve import builtin_idle
from backend.engine import warm_up
from backend.engine.core.program import KERNEL
from backend.engine.frame_tail import TAIL
from backend.session import EngineSession

pytestmark = pytest.mark.slow


def _threads(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("Threads:"):
            return int(line.split()[1])
    raise AssertionError("no thread count")


def _settled_threads(pid: int, still: float = 2.0, timeout: float = 60.0) -> int:
    """The process's thread count once it has not changed for `still` seconds (its start-up threads,
    which load compiled code and warm up paths beside the clock, have ended)."""
    deadline = time.monotonic() + timeout
    count, since = _threads(pid), time.monotonic()
    while time.monotonic() < deadline:
        time.sleep(0.1)
        now = _threads(pid)
        if now != count:
            count, since = now, time.monotonic()
        elif time.monotonic() - since >= still:
            break
    return count


def _frames_state(client) -> tuple[int, int]:
    status = client.status()
    return status["clients"]["frames"], sum(s["name"].startswith("ws-frames-") for s in status["sinks"])


def _wait_for(probe, want, what: str, timeout: float = 60.0):
    """Poll `probe()` until `want(value)`; fails with the last value after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        value = probe()
        if want(value):
            return value
        assert time.monotonic() < deadline, f"timed out waiting for {what}: last {value!r}"
        time.sleep(0.05)


async def _open_and_abort(port: int, n: int) -> None:
    """Open `n` /ws/frames clients, let each receive a frame, then drop them all without a close frame."""
    conns = [
        await websockets.connect(f"ws://127.0.0.1:{port}/ws/frames?decimate=20", max_queue=4)
        for _ in range(n)
    ]
    for c in conns:
        await asyncio.wait_for(c.recv(), 30)
    for c in conns:
        c.transport.abort()


def test_abruptly_closed_frame_clients_leave_nothing_behind():
    # A server loads its compiled code on threads of its own, from numba's on-disk cache or, on a fresh
    # clone, by compiling it for ~15 s: such a thread ending between the two counts below would read as a
    # missing client thread. Filled here first, the cache lets those threads end at once.
    assert KERNEL.wait(300) and TAIL.wait(300) and warm_up.wait(300)
    with running_server_proc("--no-previz", "--sim-servo", "0") as srv:
        asyncio.run(_open_and_abort(srv.port, 10))  # warm-up: worker threads the handlers use exist now
        _wait_for(lambda: _frames_state(srv.client), lambda v: v == (0, 0), "the warm-up clients to go")
        before = _settled_threads(srv.proc.pid)
        n = 50

        async def opened_then_aborted():
            # decimate=1000: after its first frame each handler waits ~10 s on its queue for the next,
            # which is when the clients vanish (before, a handler noticed only when a send failed)
            conns = [
                await websockets.connect(f"ws://127.0.0.1:{srv.port}/ws/frames?decimate=1000", max_queue=4)
                for _ in range(n)
            ]
            for c in conns:
                await asyncio.wait_for(c.recv(), 30)
            assert _frames_state(srv.client) == (n, n)  # each client has its sink (and its thread)
            # (a short-lived thread of the server's own, e.g. a telemetry or warm-up helper, may have ended
            # since `before`: a few are allowed for, a thread per client is not)
            assert _threads(srv.proc.pid) >= before + n - 3
            for c in conns:
                c.transport.abort()

        asyncio.run(opened_then_aborted())
        _wait_for(
            lambda: _frames_state(srv.client),
            lambda v: v == (0, 0),
            "clients.frames and the ws-frames sinks to reach 0",
        )
        # a leak is one thread per client (+50); the slack covers worker threads of the event loop's
        # default executor (at most min(32, cores + 4)) that the teardown may start on first use
        _wait_for(
            lambda: _threads(srv.proc.pid),
            lambda v: v <= before + 8,
            f"the sink threads to end (before: {before})",
        )


@pytest.fixture()
def live_server(desk):
    """The app under a real uvicorn in a thread, with graceful shutdown waiting forever for handlers
    (timeout_graceful_shutdown=None): a handler that does not notice would hang the join below."""
    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    app = create_app(session, frontend_dir=None)
    try:
        with running_app(app, timeout_graceful_shutdown=None) as (server, thread, port):
            yield session, app, server, thread, port
    finally:
        session.engine.close()


def _silent_clients(port: int):
    """A /ws/frames client while no frame ever comes (the clock is not running) and a 0.001 Hz
    telemetry subscriber: both handlers sit waiting with nothing to send."""
    frames = ws_connect(f"ws://127.0.0.1:{port}/ws/frames")
    telemetry = ws_connect(f"ws://127.0.0.1:{port}/ws/telemetry")
    telemetry.send(json.dumps({"type": "subscribe", "signals": [], "rate": 0.001}))
    assert json.loads(telemetry.recv(timeout=30))["type"] == "subscribed"
    return frames, telemetry


def test_a_frames_client_closing_while_its_handler_waits_is_noticed(live_server):
    session, app, _server, _thread, port = live_server
    hub = app.state.hub
    frames, telemetry = _silent_clients(port)
    _wait_for(
        lambda: dict(hub.clients), lambda c: c["frames"] == 1 and c["telemetry"] == 1, "both clients counted"
    )
    assert any(s.name.startswith("ws-frames-") for s in session.engine.sinks)
    frames.close()
    telemetry.close()
    _wait_for(
        lambda: dict(hub.clients),
        lambda c: c["frames"] == 0 and c["telemetry"] == 0,
        "the handlers to notice",
    )
    _wait_for(
        lambda: [s.name for s in session.engine.sinks],
        lambda names: not any(n.startswith("ws-frames-") for n in names),
        "the sink to go",
    )


def test_silent_clients_do_not_hold_a_graceful_shutdown(live_server):
    session, app, server, thread, port = live_server
    frames, telemetry = _silent_clients(port)
    server.should_exit = True  # what SIGTERM does: uvicorn then waits for every connection to end
    thread.join(60)
    assert not thread.is_alive(), "uvicorn's graceful shutdown hung on a WebSocket handler"
    assert app.state.hub.clients == {"control": 0, "telemetry": 0, "frames": 0, "previz": 0}
    assert not any(s.name.startswith("ws-frames-") for s in session.engine.sinks)
    for ws in (frames, telemetry):
        with pytest.raises(ConnectionClosed):
            while True:
                ws.recv(timeout=30)


def test_the_app_shutdown_event_closes_every_socket(live_server):
    _session, app, _server, _thread, port = live_server
    hub = app.state.hub
    frames, telemetry = _silent_clients(port)
    control = ws_connect(f"ws://127.0.0.1:{port}/ws/control")
    _wait_for(lambda: dict(hub.clients), lambda c: sum(c.values()) == 3, "three clients")
    hub.shutdown()  # what the lifespan shutdown does
    for ws in (frames, telemetry, control):
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                ws.recv(timeout=30)
        assert closed.value.rcvd.code == 1001
    _wait_for(lambda: dict(hub.clients), lambda c: sum(c.values()) == 0, "the counts to reach 0")
