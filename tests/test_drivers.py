"""Drivers: OSC over UDP, the frame recorder, and simulated servos measuring the filter's effect."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest

from backend.drivers import FrameRecorder, OscDriver, SimulatedServos, read_recording
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession


def steps_program(filtered: bool):
    b = ProgramBuilder("steps")
    src = b.node("sine", "wave", dofs=["head_yaw"], amplitude=0.5, frequency=0.5)
    gain = b.node("gain_offset", "square", gain=10.0)  # clipped at the joint limits: a near-square wave
    nodes = [src, gain] + ([b.node("nmf_stage2", "nmf", preset="D")] if filtered else []) + [b.output()]
    b.chain(*nodes)
    return b.build()


def test_recorder_round_trip(desk, tmp_path):
    session = EngineSession.create(desk, rate=50, program=steps_program(False))
    rec = session.engine.add_sink(FrameRecorder(desk, tmp_path / "r.jsonl"))
    session.engine.inject_event(
        __import__("backend.engine.frames", fromlist=["FrameEvent"]).FrameEvent(
            "speech", "say", {"text": "hi"}
        )
    )
    frames = list(session.run_headless(100))
    session.engine.close()
    t, series, events = read_recording(tmp_path / "r.jsonl")
    assert len(t) == 100 and rec.frames == 100
    np.testing.assert_allclose(
        series["head_yaw"], [f.position[desk.channel_index["head_yaw"]] for f in frames], atol=1e-9
    )
    assert events[0]["payload"]["text"] == "hi" and events[0]["t"] == 0.0


def test_osc_driver_sends_bundles(desk):
    from pythonosc.osc_bundle import OscBundle

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5)
    port = rx.getsockname()[1]
    session = EngineSession.create(desk, rate=50, program=steps_program(False))
    drv = session.engine.add_sink(OscDriver(desk, "127.0.0.1", port))
    session.execute({"type": "play_sound", "sound": "yawn"})
    sent = list(session.run_headless(3))
    data, _ = rx.recvfrom(65536)
    session.engine.close()
    rx.close()
    bundle = OscBundle(data)
    addresses = {m.address: m.params for m in bundle}
    assert "/nutty/head_yaw" in addresses and len(addresses["/nutty/eye_leds"]) == 3
    assert isinstance(addresses["/nutty/mouth"][0], int)
    # a sound with a file: its name, where to fetch it and when it starts (frame time)
    assert addresses["/nutty/sound/sound"] == ["yawn", "/api/sounds/yawn", pytest.approx(sent[0].t)]
    # Every bundle says which frame it is and carries a real time tag (not OSC's "immediately").
    seq, _t, dt = addresses["/nutty/frame"]
    assert isinstance(seq, int) and dt == pytest.approx(1 / 50)
    assert abs(bundle.timestamp - time.time()) < 60
    # ...and the joints the motors get, as the engine limited them.
    frame = next(f for f in sent if f.seq == seq)
    assert {f"/nutty/joint/{j}" for j in desk.joint_names} <= set(addresses)
    for j, name in enumerate(desk.joint_names):  # OSC floats are 32-bit
        assert addresses[f"/nutty/joint/{name}"][0] == pytest.approx(frame.joints[j], abs=1e-6)
    assert drv.errors == 0
    with pytest.raises(ValueError, match="port"):
        OscDriver(desk, "127.0.0.1", 0)


def test_simulated_servos_measure_the_filters_effect(desk):
    results = {}
    for filtered in (False, True):
        session = EngineSession.create(desk, rate=100, program=steps_program(filtered))
        servo = session.engine.add_sink(SimulatedServos(desk, bandwidth_hz=8.0))
        list(session.run_headless(400))
        session.engine.close()
        results[filtered] = servo.report()["head_yaw"]
    # the filtered command is trackable: much smaller error and servo jerk than the raw steps
    assert results[True]["max_error"] < 0.5 * results[False]["max_error"]
    assert results[True]["rms_jerk"] < 0.5 * results[False]["rms_jerk"]
