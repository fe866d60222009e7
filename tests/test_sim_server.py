"""The physics preview where users meet it: `nutty serve --sim mujoco` (status, events, stop on
contact), the Pre-Viz's physics ghost, `nutty sim report`, `nutty import --physics` and POST
/api/analyze with `physics: true`."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from server_process import free_port, server_process

pytest.importorskip("mujoco")

from fastapi.testclient import TestClient

from backend.api import create_app
from backend.api_types import ServerStatus
from backend.api_types.physics import PhysicsReport
from backend.drivers import DriverArgs, add_driver_options, build_drivers
from backend.engine.embodiment import load_embodiment
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession
from backend.sim.driver import MujocoDriver

ASSETS = Path(__file__).parent / "assets" / "robots"
NUTTY = (sys.executable, "-m", "backend.cli")
CLIPS = Path(__file__).parent.parent / "robots" / "nutty_desk" / "clips"


def _arms_crossing() -> dict:
    """two_arms holding both its postures at once: the arms cross."""
    b = ProgramBuilder("arms crossing", "both postures at once", robot="two_arms")
    rest = b.node("rest_pose", "rest")
    left = b.node("pose", "left", posture="left_in")
    right = b.node("pose", "right", posture="right_in")
    layers = [{"name": "base"}, {"name": "left", "mode": "override"}, {"name": "right", "mode": "override"}]
    mix = b.node("layer_mixer", "mix", layers=layers)
    b.connect(rest, mix, "out", "base").connect(left, mix, "out", "left").connect(right, mix, "out", "right")
    b.chain(mix, b.node("safety_limiter", "safety"), b.output())
    return b.to_dict()


def _status_until(client, test, timeout: float = 20.0) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        status = client.status()
        if test(status) or time.monotonic() > deadline:
            return status
        time.sleep(0.1)


def test_serve_sim_reports_a_contact_and_stops_the_motion(tmp_path):
    program = tmp_path / "crossing.json"
    program.write_text(json.dumps(_arms_crossing()))
    args = ("--robot", str(ASSETS / "two_arms"), "--program", str(program), "--no-previz")
    with server_process(*args, "--sim", "mujoco", "--sim-stop-on-contact") as server:
        status = _status_until(server.client, lambda s: s["simulation"]["stops"] >= 1)
        ServerStatus.model_validate(status)
        sim = status["simulation"]
        assert sim["engine"] == "mujoco" and sim["rate"] == 1000 and sim["stop_on_contact"]
        first = sim["recent_contacts"][0]
        assert first["links"] == ["left_arm", "right_arm"] and first["depth"] > 0
        assert "left_arm / right_arm" in server.output and "stopping the program's motion" in server.output
        # the program was dropped: the arms go back to rest, measured and commanded, and part
        rested = _status_until(
            server.client, lambda s: max(abs(j["measured"]) for j in s["joints"].values()) < 0.05
        )
        assert all(abs(j["commanded"]) < 0.05 for j in rested["joints"].values()), rested["joints"]
        assert rested["simulation"]["contacts"] == [] and rested["simulation"]["stops"] == 1
        assert server.client.program()["program"] is None


def test_a_sim_setting_needs_its_driver(desk):
    parser = argparse.ArgumentParser()
    add_driver_options(parser)
    with pytest.raises(ValueError, match="--sim-table needs --sim"):
        build_drivers(desk, parser.parse_args(["--sim-table", "0.1"]))
    with pytest.raises(SystemExit):  # argparse names the option and the bad value
        parser.parse_args(["--sim", "bullet"])


def test_the_previz_shows_the_physics_ghost_and_flashes_contacts():
    from backend.previz import PreViz  # lazy: viser is heavy

    emb = load_embodiment(ASSETS / "two_arms")
    session = EngineSession.create(emb, rate=100, program=_arms_crossing())
    pv = PreViz(session, port=free_port())
    try:
        frame = list(session.run_headless(1))[-1]
        pv.show(frame)
        assert not pv.physics.built  # no simulation: nothing built, nothing to toggle
        pv.physics_source = lambda: (np.array([-0.5, 0.5]), ("left_arm", "right_arm"))
        pv.show(frame)
        shown = pv.shown()
        assert shown["physics"] and shown["touching"] == ["left_arm", "right_arm"]
        # posed by the Pre-Viz's cheap poser: the left arm's frame turned -0.5 rad about its yaw axis (z)
        frames = {h.name.rsplit("/", 1)[-1]: h for h in pv.physics._poser.handles}
        assert np.allclose(frames["left_arm"].wxyz, [np.cos(-0.25), 0, 0, np.sin(-0.25)], atol=1e-9)
        flashed = {link for mesh, link in pv.physics._meshes if tuple(mesh.color) == (235, 40, 40)}
        assert flashed == {"left_arm", "right_arm"}
        pv.physics.set_visible(False)
        assert not pv.shown()["physics"]
    finally:
        pv.stop()
        session.engine.close()


def test_sim_report_and_import_physics_on_the_command_line(tmp_path):
    report = subprocess.run(
        [*NUTTY, "sim", "report", "nod", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert report.returncode == 0, report.stderr
    parsed = PhysicsReport.model_validate(json.loads(report.stdout))
    assert set(parsed.filtered.joints) >= {"neck_pitch", "head_pitch"} and parsed.physics_rate == 1000
    nod = parsed.filtered.joints["head_pitch"]
    assert 0 < nod.peak_error < parsed.raw.joints["head_pitch"].peak_error  # the filter helps
    csv = tmp_path / "tilt.csv"
    csv.write_text("time,head_pitch\n0,0\n0.5,0.2\n1.0,0\n")
    imported = subprocess.run(
        [
            sys.executable,
            "-m",
            "backend.cli",
            "import",
            str(csv),
            "--out",
            str(tmp_path / "tilt.json"),
            "--physics",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert imported.returncode == 0, imported.stderr
    assert (
        "physics:" in imported.stdout
        and "head_pitch" in imported.stdout
        and "contacts (raw)" in imported.stdout
    )


def test_analyze_answers_physics_for_a_clip(desk):
    session = EngineSession.create(desk, rate=100)
    clip = json.loads((CLIPS / "nod.json").read_text())
    with TestClient(create_app(session, frontend_dir=None)) as client:
        out = client.post("/api/analyze", json={"rate": 24, "clip": clip, "fit": False, "physics": True})
        assert out.status_code == 200, out.text
        physics = PhysicsReport.model_validate(out.json()["physics"])
        assert physics.gains == "urdf" and physics.filtered.joints["head_pitch"].peak_error > 0
        plain = client.post("/api/analyze", json={"rate": 24, "clip": clip, "fit": False}).json()
        assert plain.get("physics") is None
        # a server simulating with hardware.yaml's motors analyses with those motors too
        hardware = Path(__file__).parent.parent / "robots" / "nutty_desk" / "hardware.yaml"
        args = DriverArgs("mujoco", {"sim_hardware": str(hardware)}, argparse.Namespace())
        session.engine.add_sink(MujocoDriver.from_option(desk, args))
        served = client.post("/api/analyze", json={"rate": 24, "clip": clip, "fit": False, "physics": True})
        assert PhysicsReport.model_validate(served.json()["physics"]).gains == str(hardware)
        tracks = client.post(
            "/api/analyze", json={"rate": 24, "tracks": {"head_pitch": [0.0, 0.1]}, "physics": True}
        )
        assert tracks.status_code == 422 and tracks.json()["detail"]["field"] == "physics"
    session.engine.close()
