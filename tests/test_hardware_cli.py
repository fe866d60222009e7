"""The real-servo command line: `nutty serve --hardware-emulator` (the whole stack in a server, seen
through /api/status, /ws/telemetry, the AI's get_status and SIGTERM), `nutty serve --hardware` refusing
a bus it cannot open, and `nutty hardware check / scan / calibrate` against bus emulators."""

from __future__ import annotations

import json
import math
import signal
from pathlib import Path

import pytest
import yaml
from websockets.sync.client import connect

from backend.cli import main
from backend.engine.embodiment import load_embodiment
from backend.hardware.bus import HardwareError
from backend.hardware.config import load_hardware
from backend.hardware.emulator.dynamixel import DynamixelEmulator
from backend.hardware.emulator.feetech import FeetechEmulator
from backend.hardware.tools import PATIENCE_S, Calibration
from tests.emulated_hardware import emulated_hardware_file
from tests.joint_truth import ROBOTS
from tests.server_process import server_process

HARDWARE = ROBOTS / "nutty_desk" / "hardware.yaml"
TICKS_PER_RAD = 4096 / (2 * math.pi)


@pytest.mark.server
def test_serve_with_emulated_servos_reports_them_and_parks_then_powers_off(tmp_path):
    hardware = emulated_hardware_file(tmp_path)
    with server_process("--hardware-emulator", str(hardware), "--no-previz") as server:
        status = server.client.status()
        hardware = status["hardware"]
        assert hardware["state"] == "running" and hardware["emulated"] is True
        assert [b["driver"] for b in hardware["buses"]] == ["dynamixel", "feetech", "pca9685"]
        joints = status["joints"]
        assert len(joints) == 9
        assert joints["eyelid_left"]["measured"] is None  # a hobby servo cannot report its position
        assert isinstance(joints["head_yaw"]["measured"], float)
        with connect(f"{server.ws_url}/ws/telemetry") as ws:
            ws.send(json.dumps({"type": "subscribe", "signals": [], "frames": True, "rate": 30}))
            for _ in range(30):
                message = json.loads(ws.recv(timeout=5))
                if message.get("measured"):
                    break
            assert set(message["measured"]) == set(joints)
        answer = server.client.call_tool("get_status")
        assert set(answer["joints"]) == set(joints) and answer["hardware"]["state"] == "running"
        server.signal(signal.SIGTERM)
        assert server.wait_exit(20)
        assert server.proc.returncode == 0
        assert "hardware: stopped; torque off" in server.output


@pytest.mark.server
def test_serve_refuses_a_bus_it_cannot_open_in_one_line(tmp_path, capsys):
    data = yaml.safe_load(HARDWARE.read_text())
    data["buses"] = [data["buses"][0]]
    data["buses"][0]["port"] = "/dev/ttyNOPE"
    path = tmp_path / "hardware.yaml"
    path.write_text(yaml.safe_dump(data))
    code = main(["serve", "--no-previz", "--port", "0", "--hardware", str(path)])
    err = capsys.readouterr().err
    assert code == 2
    assert "/dev/ttyNOPE" in err and err.count("\n") == 1


def test_check_lists_each_joint_range_in_servo_units_and_names_a_bad_field(tmp_path, capsys):
    assert main(["hardware", "check", str(HARDWARE)]) == 0
    out = capsys.readouterr().out
    assert "head_yaw" in out and "[-1.2, 1.2] rad -> [1266, 2830] ticks" in out
    data = yaml.safe_load(HARDWARE.read_text())
    data["buses"][0]["joints"]["body_yaw"]["zero"] = 500
    bad = tmp_path / "hardware.yaml"
    bad.write_text(yaml.safe_dump(data))
    assert main(["hardware", "check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "buses[0].joints.body_yaw" in err and "beyond what the servo accepts" in err


def test_scan_lists_the_servos_on_a_dynamixel_and_a_feetech_bus(capsys):
    with DynamixelEmulator({1: 1020, 7: 1060}) as dxl:
        dxl.set_position(7, 1000)
        assert main(["hardware", "scan", "--port", dxl.path, "--ids", "0-20"]) == 0
    out = capsys.readouterr().out
    assert "2 servo(s)" in out and "XM430-W350" in out and "XL430-W250" in out and "position 1000" in out
    with FeetechEmulator({3: "STS3215"}) as sts:
        assert (
            main(["hardware", "scan", "--driver", "feetech", "--port", sts.path, "--ids", "1-5", "--json"])
            == 0
        )
    found = json.loads(capsys.readouterr().out)
    assert [(s["id"], s["model_name"]) for s in found["servos"]] == [(3, "STS3215")]


def _first_bus_on(dxl: DynamixelEmulator, tmp_path: Path) -> Path:
    """The bundled hardware file cut to its first (Dynamixel) bus, on the emulator's port."""
    data = yaml.safe_load(HARDWARE.read_text())
    data["buses"] = [data["buses"][0]]
    data["buses"][0]["port"] = dxl.path
    path = tmp_path / "hardware.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_calibrate_walks_a_joint_and_writes_zero_and_direction(tmp_path, monkeypatch, capsys):
    with DynamixelEmulator(dict.fromkeys(range(1, 6), 1020)) as dxl:
        path = _first_bus_on(dxl, tmp_path)
        moves = iter([2200, 2200 - round(0.6 * TICKS_PER_RAD)])  # by hand: zero, then +0.6 rad (reversed)

        def answer(prompt: str) -> str:
            dxl.set_position(3, next(moves))
            return ""

        monkeypatch.setattr("builtins.input", answer)
        code = main(["hardware", "calibrate", str(path), "--joint", "head_yaw"])
        assert code == 0, capsys.readouterr().err
        assert not dxl.torque(3)  # it stays limp: the joint was moved by hand
    written = yaml.safe_load(path.read_text())["buses"][0]["joints"]["head_yaw"]
    assert (written["zero"], written["direction"], written["id"]) == (2200, -1, 3)
    assert Path(f"{path}.bak").exists()


def test_calibration_waits_for_a_late_servo_but_not_for_ever(tmp_path):
    """A person waits at the calibration, not a clock: a servo that is late to answer (a busy machine, a
    pty's far end held off) is asked again for up to PATIENCE_S; one that never answers is named."""
    with DynamixelEmulator(dict.fromkeys(range(1, 6), 1020)) as dxl:
        path = _first_bus_on(dxl, tmp_path)
        emb = load_embodiment("nutty_desk")
        hardware = load_hardware(path, emb)
        late = Calibration(hardware, emb, "head_yaw")
        dxl.silence(3, PATIENCE_S / 3)  # longer than the bus's own retries (2 x ~10 ms)
        try:
            late.start()
            assert not dxl.torque(3)
            dxl.set_position(3, 2100)
            dxl.silence(3, PATIENCE_S / 3)
            assert late.read() == 2100
        finally:
            late.bus.close()
        gone = Calibration(hardware, emb, "head_yaw")
        dxl.silence(3, 10 * PATIENCE_S)
        try:
            with pytest.raises(HardwareError, match="head_yaw: no answer from id 3"):
                gone.start()
        finally:
            gone.bus.close()


def test_the_engine_less_player_and_bridge_refuse_real_servos(tmp_path, capsys):
    recording = tmp_path / "take.jsonl"
    recording.write_text("")
    assert main(["play", str(recording), "--robot", "nutty_desk", "--hardware", str(HARDWARE)]) == 2
    assert "--hardware runs only in `nutty serve`" in capsys.readouterr().err
    bridge = [
        "bridge",
        "--zenoh",
        "--robot-id",
        "r1",
        "--robot",
        "nutty_desk",
        "--driver",
        "hardware-emulator",
    ]
    code = main([*bridge, "--hardware-emulator", str(HARDWARE)])
    assert code != 0
    assert "--hardware-emulator runs only in `nutty serve`" in capsys.readouterr().err


def test_real_servos_never_run_without_the_safety_net(capsys):
    assert main(["serve", "--no-previz", "--hardware", str(HARDWARE), "--unsafe-no-limits"]) == 2
    assert "--unsafe-no-limits is refused with --hardware" in capsys.readouterr().err
