"""The real-servo driver (backend.hardware) end to end in one process: the engine, the driver and its
bus threads, the vendors' SDKs, and bus emulators on pseudo-terminals written from the protocol
documents (backend/hardware/emulator). Joint limits come from tests/joint_truth.py, read from the
robot's files independently of the engine."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.engine.embodiment import load_embodiment
from backend.hardware.bus import HardwareError
from backend.hardware.config import check_against, parse_hardware
from backend.hardware.emulated import EmulatedHardwareDriver
from backend.session import EngineSession
from tests.joint_truth import ROBOTS, joint_truth

TICKS_PER_RAD = 4096 / (2 * math.pi)
HEAD = {"body_yaw": 1, "neck_pitch": 2, "head_yaw": 3, "head_pitch": 4, "head_roll": 5}


def hardware_file(**settings):
    """nutty_desk's head on a Dynamixel bus, its ears on a Feetech one (the ports are replaced by the
    emulators'); generous timeouts unless a test asks, as the emulators share this busy process."""
    data = {
        "buses": [
            {
                "driver": "dynamixel",
                "port": "/dev/null",
                "joints": {
                    n: {"id": i, "zero": 2048, "direction": -1 if n == "neck_pitch" else 1}
                    for n, i in HEAD.items()
                },
            },
            {
                "driver": "feetech",
                "port": "/dev/null",
                "joints": {
                    "ear_left": {"id": 1, "zero": 2048},
                    "ear_right": {"id": 2, "zero": 2048, "direction": -1},
                },
            },
        ],
        "no_answer_ms": 500,
        **settings,
    }
    return data


@pytest.fixture(scope="module")
def emb():
    return load_embodiment(ROBOTS / "nutty_desk")


@pytest.fixture(scope="module")
def truth():
    return joint_truth(ROBOTS / "nutty_desk")


def make(emb, buses=None, **settings):
    data = hardware_file(**settings)
    hardware = parse_hardware({**data, "buses": buses} if buses else data)
    check_against(hardware, emb)
    session = EngineSession.create(emb, rate=100.0)
    session.load_program((ROBOTS / "nutty_desk" / "programs" / "interactive.json").read_text())
    driver = EmulatedHardwareDriver(emb, hardware)
    session.engine.add_sink(driver)
    return session, driver


def wait_for(predicate, timeout=3.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


def test_a_missing_servo_stops_the_start_naming_joint_and_id_and_nothing_is_powered(emb):
    session, driver = make(emb)
    dxl = driver.emulators[0]
    dxl.missing.add(3)
    try:
        with pytest.raises(HardwareError) as info:
            driver.prepare(session.engine)
        lines = str(info.value).splitlines()
        assert lines == [f"head_yaw: no answer from id 3 on {dxl.path}"]
        assert not any(dxl.torque(i) for i in (1, 2, 4, 5))
        assert session.engine.seq == 0
    finally:
        session.engine.close()


def test_the_engine_starts_where_the_robot_stands_and_blends_within_every_joint_limit(emb, truth):
    session, driver = make(emb)
    dxl, sts = driver.emulators[:2]
    stand = {"head_yaw": 0.9, "body_yaw": -1.1, "neck_pitch": -0.3}
    for name, value in stand.items():
        direction = -1 if name == "neck_pitch" else 1
        dxl.set_position(HEAD[name], round(2048 + direction * value * TICKS_PER_RAD))
    sts.set_position(1, round(2048 + 0.5 * TICKS_PER_RAD))
    try:
        driver.prepare(session.engine)
        names = list(emb.joint_names)
        # before torque came on, each goal register was set to where the servo stands (no power-up jump)
        assert dxl.goal(HEAD["head_yaw"]) == round(2048 + 0.9 * TICKS_PER_RAD)
        assert all(dxl.torque(i) for i in HEAD.values())
        frames = session.engine.run_ticks(300)
        q = np.array([f.joint_values(emb) for f in frames])
        for name, value in {**stand, "ear_left": 0.5}.items():
            assert q[0, names.index(name)] == pytest.approx(value, abs=2 / TICKS_PER_RAD), name
        standing = np.array(q[0])
        for name, value in {**stand, "ear_left": 0.5}.items():
            standing[names.index(name)] = round(value * TICKS_PER_RAD) / TICKS_PER_RAD
        # standing still at the measured pose, then the frames: within every joint limit
        truth.assert_within(np.vstack([standing, standing, standing, q]), 100.0, "start from measured")
        program = session.engine.apu is not None
        assert program and abs(q[-1, names.index("head_yaw")]) < 0.5  # it reached the program's pose
    finally:
        session.engine.close()


def test_goals_follow_the_engine_and_positions_come_back_per_joint(emb):
    session, driver = make(emb)
    try:
        driver.prepare(session.engine)
        session.engine.start()
        assert wait_for(lambda: all(w.reads >= 20 for w in driver.workers if w.bus.reads_position), 5.0)
        readings = driver.joint_readings()
        assert set(readings) == set(HEAD) | {"ear_left", "ear_right"}
        for name, r in readings.items():
            assert set(r) == {"commanded", "measured", "error", "effort", "saturated"}
            assert r["error"] == pytest.approx(r["commanded"] - r["measured"], abs=1e-5), name
            assert abs(r["error"]) < 0.1, (name, r)
        status = driver.hardware_status()
        assert status["state"] == "running" and status["faults"] == [] and status["emulated"] is True
        dxl_status = status["buses"][0]
        assert dxl_status["driver"] == "dynamixel" and dxl_status["joints"] == list(HEAD)
        assert dxl_status["writes"] >= dxl_status["reads"] > 0
        # one SYNC WRITE per goal transaction: the emulator counted exactly as many as the driver sent
        assert driver.emulators[0].counts["sync_write"] == dxl_status["writes"] or wait_for(
            lambda: driver.emulators[0].counts["sync_write"] >= dxl_status["writes"]
        )
    finally:
        session.engine.close()


def test_an_overload_holds_the_joint_fades_the_rest_to_rest_and_is_reported(emb, truth):
    session, driver = make(emb)
    dxl = driver.emulators[0]
    joints: list[np.ndarray] = []
    session.engine.add_frame_observer(lambda f: joints.append(f.joint_values(emb)))
    notes: list[dict] = []
    session.on_note(notes.append)
    try:
        driver.prepare(session.engine)
        session.engine.start()
        time.sleep(1.0)
        dxl.set_fault(HEAD["head_yaw"], "overload")
        assert wait_for(lambda: driver.faults, 2.0), "the overload was never seen"
        fault = driver.faults[0]
        assert (fault["joint"], fault["servo"], fault["fault"], fault["bus"]) == (
            "head_yaw",
            3,
            "overload",
            dxl.path,
        )
        assert wait_for(lambda: any(n.get("event") == "servo_fault" for n in notes), 2.0)
        goal_at_fault = dxl.goal(HEAD["head_yaw"])
        time.sleep(2.5)
        assert session.engine.apu is None  # the program was dropped
        assert dxl.goal(HEAD["head_yaw"]) == goal_at_fault  # the faulted servo got no more goals
        assert driver.hardware_status()["state"] == "faulted"
        names = list(emb.joint_names)
        last = joints[-1]
        rest = emb.joint_positions(emb.rest)
        others = [k for k, n in enumerate(names) if n != "head_yaw"]
        assert np.allclose(last[others], rest[others], atol=1e-6)
        truth.assert_within(np.array(joints), 100.0, "fault fade")
    finally:
        session.engine.close()


def test_a_silent_servo_is_a_no_answer_fault_but_a_corrupt_reply_is_not(emb):
    session, driver = make(emb)
    dxl = driver.emulators[0]
    try:
        driver.prepare(session.engine)
        session.engine.start()
        time.sleep(0.5)
        dxl.corrupt_replies(HEAD["neck_pitch"], 2)
        assert wait_for(lambda: driver.workers[0].missed >= 2, 2.0)
        time.sleep(0.3)
        assert driver.faults == []
        dxl.silence(HEAD["body_yaw"], 2.0)
        assert wait_for(lambda: driver.faults, 2.0)
        assert [(f["joint"], f["fault"]) for f in driver.faults] == [("body_yaw", "no_answer")]
    finally:
        session.engine.close()


@pytest.mark.parametrize("keep", [False, True])
def test_stop_parks_at_rest_then_switches_torque_off_unless_kept(emb, keep):
    session, driver = make(emb, torque_on_exit=keep)
    dxl, sts = driver.emulators[:2]
    dxl.set_position(HEAD["head_yaw"], 2048 + 500)
    try:
        driver.prepare(session.engine)
        session.engine.start()
        time.sleep(0.5)
        assert session.engine.park(timeout=5.0)["reached_rest"]
    finally:
        session.engine.close()
    assert all(dxl.torque(i) is keep for i in HEAD.values())
    assert all(sts.state(i).torque is keep for i in (1, 2))
    rest = emb.joint_positions(emb.rest)[list(emb.joint_names).index("head_yaw")]
    assert dxl.position(HEAD["head_yaw"]) == pytest.approx(2048 + rest * TICKS_PER_RAD, abs=3)
    assert driver.hardware_status()["state"] == "stopped"


def test_a_servo_fault_reaches_control_clients_as_an_event(emb):
    session, driver = make(emb)
    try:
        driver.prepare(session.engine)
        session.engine.start()
        with TestClient(create_app(session, frontend_dir=None)) as client:
            with client.websocket_connect("/ws/control") as ws:
                time.sleep(0.3)
                driver.emulators[1].set_fault(2, "overheat")  # ear_right, on the Feetech bus
                for _ in range(200):
                    message = ws.receive_json()
                    if message.get("event") == "servo_fault":
                        break
            assert (
                message["joint"] == "ear_right" and message["servo"] == 2 and message["fault"] == "overheat"
            )
            status = client.get("/api/status").json()
            assert status["hardware"]["state"] == "faulted"
            assert [f["joint"] for f in status["hardware"]["faults"]] == ["ear_right"]
    finally:
        session.engine.close()


def test_a_pwm_board_that_stops_answering_is_a_fault_of_its_joints(emb):
    pwm = {
        "driver": "pca9685",
        "joints": {
            "eyelid_left": {"channel": 0, "pulse_us": {0.0: 1000, 1.3: 1830}},
            "eyelid_right": {"channel": 1, "pulse_us": {0.0: 2000, 1.3: 1170}},
        },
    }
    session, driver = make(emb, buses=[pwm])
    chip = driver.emulators[0]
    try:
        driver.prepare(session.engine)
        session.engine.start()
        assert wait_for(lambda: driver.workers[0].reads >= 10, 3.0)
        assert driver.faults == [] and driver.workers[0].missed == 0
        assert chip.pulse_us(0) == pytest.approx(
            1000 + 0.15 * 830 / 1.3, abs=6
        )  # the eyelid's rest, 0.15 rad
        chip.present = False
        assert wait_for(lambda: len(driver.faults) == 2, 3.0)
        assert {(f["joint"], f["fault"]) for f in driver.faults} == {
            ("eyelid_left", "no_answer"),
            ("eyelid_right", "no_answer"),
        }
    finally:
        session.engine.close()


def test_a_servo_whose_position_limits_cut_the_urdf_range_stops_the_start(emb):
    session, driver = make(emb)
    dxl = driver.emulators[0]
    dxl.write_table(HEAD["body_yaw"], 48, (3000).to_bytes(4, "little"))  # Max Position Limit
    try:
        with pytest.raises(HardwareError) as info:
            driver.prepare(session.engine)
        message = str(info.value)
        assert message.startswith(f"body_yaw (id 1) on {dxl.path}: its URDF range needs ticks [353, 3743]")
        assert "accepts only [0, 3000]" in message
        assert not any(dxl.torque(i) for i in HEAD.values())
    finally:
        session.engine.close()
