"""The Pre-Viz in its own process (what `nutty serve` runs): frames reach the child's scene, the ghost
toggle, gaze drags (set in the server's session, trusted clients only), and a clean stop."""

from __future__ import annotations

import time

import numpy as np
import pytest
from server_process import free_port

from backend.engine.sinks import Sink
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession


def wait_until(predicate, timeout: float = 30.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


@pytest.fixture()
def remote(desk):
    from backend.previz_process import PreVizProcess

    b = ProgramBuilder("gaze")
    b.expose("gaze_target", type="vec3", default=[1.0, 0.0, 0.3])
    b.chain(
        b.node("sine", "s", dofs=["head_yaw"], amplitude=0.3, frequency=0.5),
        b.node("nmf_stage2", "nmf"),
        b.output(),
    )
    session = EngineSession.create(desk, rate=100, program=b.build())
    pv = PreVizProcess(session, port=free_port())
    pv.wait_ready()
    pv.start()
    yield pv
    pv.stop()
    session.engine.close()


def test_frames_reach_the_childs_scene(remote, desk):
    engine = remote.session.engine
    sent: list = []
    engine.add_sink(Sink("all-frames", sent.append, max_queue=1000))
    engine.start()
    wait_until(lambda: remote.frames_shown >= 5, what="frames shown by the Pre-Viz process")
    engine.stop()
    time.sleep(0.3)  # the last frame sent reaches the scene
    shown = remote.shown()
    # The Pre-Viz takes every other frame at 100 Hz (it draws at most MAX_RATE a second), so the one
    # it shows is one of the last two: shown exactly, joint value for joint value.
    last_yaws = [f.position[desk.channel_index["head_yaw"]] for f in sent[-2:]]
    assert all(abs(y) > 1e-3 for y in last_yaws)  # the sine moved it
    assert any(shown["joints"]["head_yaw"] == pytest.approx(y, abs=1e-9) for y in last_yaws), (
        shown["joints"]["head_yaw"],
        last_yaws,
    )
    assert shown["ghost"] is True
    assert remote.session.engine.stats()["sinks"][0]["name"] == "previz"


def test_ghost_toggle_goes_through_the_child(remote):
    remote.set_ghost(False)
    assert remote.ghost_visible is False and remote.shown()["ghost"] is False
    remote.set_ghost(True)
    assert remote.ghost_visible is True and remote.shown()["ghost"] is True


def test_gaze_drags_set_the_servers_input_from_trusted_clients_only(remote):
    import viser
    from websockets.sync.client import connect

    session = remote.session
    assert remote.drag_gaze([0.5, 0.2, 0.4])  # from this process: always counts
    session.engine.tick()
    assert session.inputs()["gaze_target"] == pytest.approx([0.5, 0.2, 0.4])
    assert not remote.drag_gaze([0.4, -0.2, 0.3], client_id=12345)  # never passed the checks
    session.engine.tick()
    assert session.inputs()["gaze_target"] == pytest.approx([0.5, 0.2, 0.4])
    url = f"ws://127.0.0.1:{remote.port}"
    with connect(
        url,
        subprotocols=[f"viser-v{viser.__version__}"],
        origin=f"http://localhost:{remote.port}",
        max_size=None,
        open_timeout=30,
    ) as ws:
        ws.recv(timeout=30)
        wait_until(lambda: len(remote.trusted_clients) == 1, what="the child's report of a trusted client")
        (client_id,) = remote.trusted_clients
        assert remote.drag_gaze([0.4, -0.2, 0.3], client_id=client_id)
    session.engine.tick()
    assert session.inputs()["gaze_target"] == pytest.approx([0.4, -0.2, 0.3])


def test_loopback_only_and_a_stopped_child_is_gone(desk):
    from backend.previz_process import PreVizProcess, PreVizUnavailable

    session = EngineSession.create(desk, rate=100)
    with pytest.raises(ValueError, match="loopback"):
        PreVizProcess(session, host="0.0.0.0", port=free_port())
    pv = PreVizProcess(session, port=free_port())
    pv.wait_ready()
    pv.start()
    pv.stop()
    assert not pv.alive
    assert not [s for s in session.engine.sinks if s.name == "previz"]
    with pytest.raises(PreVizUnavailable):
        pv.shown()
    pv.show(session.engine.tick())  # a frame for a Pre-Viz that has gone changes nothing
    session.engine.close()


def test_a_child_that_dies_leaves_the_engine_running(remote):
    engine = remote.session.engine
    engine.start()
    wait_until(lambda: remote.frames_shown >= 1, what="a first frame")
    remote._proc.kill()
    remote._proc.join(5)
    ticks = engine.ticks
    wait_until(lambda: engine.ticks > ticks + 20, what="ticks after the Pre-Viz died")
    assert np.isfinite(engine.last_frame.position).all()
    engine.stop()


def test_with_a_server_a_drag_is_a_logged_set_gaze_command_and_a_refused_one_moves_nothing(remote):
    """Gizmo drags travel the command path REST uses (validated, logged, evented), not a side door."""
    from backend.api import create_app

    app = create_app(remote.session, previz=remote, frontend_dir=None)
    hub = app.state.hub
    seen: list = []
    hub.listeners.append(seen.append)
    assert remote.drag_gaze([0.6, 0.1, 0.35])
    remote.session.engine.tick()
    assert remote.session.inputs()["gaze_target"] == pytest.approx([0.6, 0.1, 0.35])
    (event,) = [m for m in seen if m.get("command") == "set_gaze"]
    assert event["event"] == "completed" and hub.commands.get(event["id"])["type"] == "set_gaze"
    assert not remote.drag_gaze([float("nan"), 0.0, 0.3])  # refused by the command's validation
    remote.session.engine.tick()
    assert remote.session.inputs()["gaze_target"] == pytest.approx([0.6, 0.1, 0.35])


def test_with_a_token_the_childs_port_serves_nobody_but_the_proxy(desk):
    import viser
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from backend.previz_process import PreVizProcess

    session = EngineSession.create(desk, rate=100)
    pv = PreVizProcess(session, port=free_port(), proxy_only=True)
    try:
        pv.wait_ready()
        url = f"ws://127.0.0.1:{pv.port}"
        with (
            connect(
                url,
                subprotocols=[f"viser-v{viser.__version__}"],
                origin=f"http://localhost:{pv.port}",
                max_size=None,
                open_timeout=30,
            ) as ws,
            pytest.raises(ConnectionClosed) as closed,
        ):
            while True:
                ws.recv(timeout=30)
        assert closed.value.rcvd.code == 4403 and "token" in closed.value.rcvd.reason
        assert pv.trusted_clients == frozenset()
    finally:
        pv.stop()
        session.engine.close()
