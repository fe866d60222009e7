"""The puppet layer of the interactive program: `puppet` commands pull the robot toward a streamed pose
through stage 2; a watchdog fades the layer out when the stream stops; bad targets change nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.control import CommandError
from backend.session import EngineSession

INTERACTIVE = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs" / "interactive.json"
RATE = 100.0


@pytest.fixture()
def session(desk):
    return EngineSession.create(desk, rate=RATE, program_text=INTERACTIVE.read_text())


def run(session, seconds, message=None):
    """Tick for `seconds`, sending `message` before every tick (a 100 Hz stream) when given."""
    frames = []
    for _ in range(round(seconds * RATE)):
        if message is not None:
            session.execute(message)
        frames += list(session.run_headless(1, []))
    return frames


def puppet_weight(session) -> float:
    return float(session.engine.apu.signal_value("puppet", "weight"))


def within_limits(desk, frames) -> None:
    c = desk.continuous_mask
    slack = 1 + 1e-6
    for f in frames:
        assert np.all(f.position[c] >= desk.min[c] - 1e-9) and np.all(f.position[c] <= desk.max[c] + 1e-9)
        assert np.all(np.abs(f.velocity[c]) <= desk.vel_limit[c] * slack)
        assert np.all(np.abs(f.acceleration[c]) <= desk.acc_limit[c] * slack)
        assert np.all(np.abs(f.jerk[c]) <= desk.jerk_limit[c] * slack)


def test_stream_pulls_the_output_to_the_pose_then_the_watchdog_fades_it_out(session, desk):
    yaw, ear = desk.dof("head_yaw").channels.start, desk.dof("ear_left").channels.start
    idle = run(session, 1.0)
    assert puppet_weight(session) == 0.0
    before = idle[-1].position[yaw]
    pose = {
        "type": "puppet",
        "values": {"head_yaw": 0.7, "ear_left": -0.5, "mouth": "grin", "eye_leds": [1, 0, 0]},
    }
    live = run(session, 2.5, pose)
    assert puppet_weight(session) == 1.0
    assert abs(live[-1].position[yaw] - 0.7) < 0.01 and abs(live[-1].position[ear] + 0.5) < 0.01
    mouth = desk.dof("mouth")
    assert live[-1].position[mouth.channels.start] == mouth.options.index("grin")
    assert np.allclose(live[-1].position[desk.dof("eye_leds").channels], [1, 0, 0], atol=0.01)
    assert live[0].position[yaw] - before < 0.05  # no jump: the layer fades in, stage 2 filters
    silent = run(session, 0.45)  # within the 0.5 s timeout: still held
    assert puppet_weight(session) == 1.0 and abs(silent[-1].position[yaw] - 0.7) < 0.01
    after = run(session, 2.5)  # the stream dropped: the watchdog fades the layer out
    assert puppet_weight(session) == 0.0
    assert abs(after[-1].position[yaw] - before) < 0.1
    within_limits(desk, idle + live + silent + after)


def test_release_fades_out_at_once_and_a_new_stream_starts_clean(session, desk):
    yaw, ear = desk.dof("head_yaw").channels.start, desk.dof("ear_left").channels.start
    run(session, 1.0, {"type": "puppet", "values": {"head_yaw": -0.6, "ear_left": 0.5}})
    assert session.execute({"type": "puppet", "release": True})["released"] is True
    run(session, 0.3)
    assert 0.0 < puppet_weight(session) < 1.0  # fading out over fade_out (0.5 s)
    run(session, 0.4)
    assert puppet_weight(session) == 0.0
    frames = run(session, 2.0, {"type": "puppet", "values": {"head_yaw": 0.3}})
    assert abs(frames[-1].position[yaw] - 0.3) < 0.01
    assert abs(frames[-1].position[ear]) < 0.15  # the old ear target was forgotten
    layer = session.engine.apu.signal_value("puppet", "out")
    assert layer.mask[yaw] and not layer.mask[ear]


@pytest.mark.parametrize(
    "message, field",
    [
        ({"values": {"head_yaw": 1.5}}, "values.head_yaw"),  # beyond its limit (1.2 rad)
        ({"values": {"head_yaw": True}}, "values.head_yaw"),
        ({"values": {"nope": 0.1}}, "values.nope"),
        ({"values": {"speech": 0.1}}, "values.speech"),
        ({"values": {"mouth": "sneer"}}, "values.mouth"),
        ({"values": {"eye_leds": [1, 0]}}, "values.eye_leds"),
        ({"values": {}}, "values"),
        ({"values": [0.1]}, "values"),
        ({"values": {"head_yaw": 0.1}, "release": True}, "release"),
    ],
)
def test_bad_messages_change_nothing(session, message, field):
    run(session, 0.2, {"type": "puppet", "values": {"head_yaw": 0.2}})
    block = session.engine.apu.steps[session.engine.apu.index["puppet"]].block
    before = (block.state.values.copy(), block.state.mask.copy(), block.state.silence)
    with pytest.raises(CommandError) as err:
        session.execute({"type": "puppet", **message})
    assert err.value.field == field
    assert np.array_equal(block.state.values, before[0]) and np.array_equal(block.state.mask, before[1])
    assert block.state.silence == before[2]


def test_puppet_over_the_control_socket(session):
    session.engine.start()
    try:
        with (
            TestClient(create_app(session, frontend_dir=None)) as client,
            client.websocket_connect("/ws/control") as ws,
        ):
            ws.send_json({"type": "puppet", "id": "p1", "values": {"head_roll": 0.2}})
            msgs = [ws.receive_json() for _ in range(2)]  # its ack and its `completed` event, in any order
            ack = next(m for m in msgs if m["type"] == "ack")
            assert ack["id"] == "p1" and ack["result"]["dofs"] == ["head_roll"]
            ws.send_json({"type": "puppet", "id": "p2", "values": {"head_roll": 9}})
            error = ws.receive_json()
            assert error["id"] == "p2" and error["field"] == "values.head_roll"
            assert "outside its limits" in error["message"]
    finally:
        session.engine.close()


def test_the_envelope_is_the_mixer_fade_law(desk):
    """The block's scalar envelope follows blend.advance_fades exactly, through fade-in, the watchdog's
    fade-out and a fresh stream (it was computed with that array function before it was made scalar)."""
    from backend.engine.blend import advance_fades
    from backend.engine.blocks.base import BlockContext
    from backend.engine.blocks.puppet import Puppet, PuppetParams

    block = Puppet(PuppetParams(timeout=0.2, fade_in=0.3, fade_out=0.45), BlockContext(desk, 100.0), "p")
    env, silence, live, seen, expected = np.zeros(1), 0.0, False, [], []
    for k in range(200):
        if k in (0, 5, 10, 120):  # messages; silence between 10 and 120 trips the watchdog
            block.handle("set", {"channels": [0], "values": [0.1]})
            silence, live = 0.0, True
        out = block.tick(0.01, {})
        silence += 0.01
        live = live and silence <= 0.2
        env = advance_fades(env, np.array([1.0 if live else 0.0]), np.array([0.3 if live else 0.45]), 0.01)
        e = float(env[0])
        expected.append(e * e * (3.0 - 2.0 * e))
        seen.append(out["weight"])
        assert out["live"] is live
    assert seen == expected
    assert max(seen) > 0.0 and seen[100] == 0.0 and seen[135] > 0.0 and seen[-1] == 0.0
