"""docs/architecture.md's worked examples run as written: a block with a drivable parameter, a long-action
command (an AI tool too), a driver, an importer and an editor panel are each the one file the page says,
registered by the entry-point lines it gives (installed as a throwaway distribution), and work end to end."""

from __future__ import annotations

import contextlib
import json
import math
import re
import socket
import sys
import tomllib
import types
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.drivers import add_driver_options, build_drivers
from backend.engine.blocks import block_catalog
from backend.graph.builder import ProgramBuilder
from backend.importers import detect_format, import_clip
from backend.session import EngineSession
from tests.plugin_dist import installed

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "architecture.md").read_text()
INTERACTIVE = ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json"


def example(name: str) -> str:
    """The fenced code block that follows `<!-- example: name -->` in the page."""
    m = re.search(rf"<!-- example: {name} -->\s*```\w+\n(.*?)```", DOC, re.S)
    assert m, f"docs/architecture.md has no example '{name}'"
    return m.group(1)


def load(name: str, module: str) -> types.ModuleType:
    """Run an example as the module the page says it is (dataclasses and pydantic look modules up)."""
    mod = types.ModuleType(module)
    sys.modules[module] = mod
    exec(compile(example(name), f"docs/architecture.md:{name}", "exec"), mod.__dict__)
    return mod


def entry_points(name: str) -> dict[str, dict[str, str]]:
    """The `[project.entry-points."nutty.x"]` lines of an example, as group -> {name -> "module:Class"}."""
    return tomllib.loads(example(name))["project"]["entry-points"]


@pytest.fixture()
def example_module(tmp_path):
    """Load an example as its module, registered by the example's entry-point lines."""
    with contextlib.ExitStack() as stack:

        def use(name: str, module: str) -> types.ModuleType:
            mod = load(name, module)
            stack.callback(sys.modules.pop, module, None)
            stack.enter_context(installed(tmp_path / name, f"docs-{name}", entry_points(f"{name}-entry")))
            return mod

        yield use


@pytest.fixture()
def sway(example_module):
    return example_module("block", "backend.engine.blocks.sway")


def test_block_example_registers_and_its_drivable_parameter_is_a_port(desk, sway):
    entry = next(e for e in block_catalog() if e["type"] == "sway")
    assert entry["category"] == "operators"
    assert set(entry["inputs"]) >= {"in", "amount"} and entry["inputs"]["amount"]["type"] == "float"

    b = ProgramBuilder("sway")
    rest = b.node("pose", "rest", posture="neutral")
    sway_node = b.node("sway", "sway", dofs=["body_yaw"], amount=0.2, period=2.0)
    b.chain(rest, sway_node, b.output())
    session = EngineSession.create(desk, rate=50, program=b.build())
    frames = list(session.run_headless(150))
    session.engine.close()
    i = desk.channel_index["body_yaw"]
    program = np.array([f.program[i] for f in frames])  # the program's own output
    t = np.arange(1, 151) / 50
    assert np.allclose(program, 0.2 * np.sin(2 * np.pi * t / 2.0), atol=1e-9)
    # Starting at full speed from rest is beyond the robot's limits: the safety net eases it in, then
    # passes the program through untouched.
    out = np.array([f.position[i] for f in frames])
    assert not np.allclose(out[:5], program[:5]) and np.array_equal(out[-50:], program[-50:])


def test_block_example_amount_follows_a_wired_signal(desk, sway):
    b = ProgramBuilder("sway-driven")
    rest = b.node("pose", "rest", posture="neutral")
    sway_node = b.node("sway", "sway", dofs=["body_yaw"], amount=0.0, period=2.0)
    lfo = b.node("math", "amount", op="add", a=0.05, b=0.0)
    b.chain(rest, sway_node, b.output())
    b.connect(lfo, sway_node, "value", "amount")
    session = EngineSession.create(desk, rate=50, program=b.build())
    frames = list(session.run_headless(25))
    session.engine.close()
    yaw = frames[-1].program[desk.channel_index["body_yaw"]]
    assert yaw == pytest.approx(0.05 * math.sin(2 * math.pi * 0.5 / 2.0), abs=1e-9)


@pytest.fixture()
def fall_asleep(example_module):
    return example_module("command", "backend.control.sleep").FallAsleep


def test_command_example_is_a_long_action_over_rest(desk, fall_asleep):
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE.read_text())
    try:
        with TestClient(create_app(session, frontend_dir=None)) as client:
            schema = client.get("/api/schema/commands").json()
            assert "fall_asleep" in schema["discriminator"]["mapping"]
            ack = client.post(
                "/api/commands", json={"id": "z1", "type": "fall_asleep", "duration": 0.2}
            ).json()
            assert ack == {"id": "z1", "status": "started", "result": {"posture": "sleepy", "duration": 0.2}}
            cid = "z1"
            for _ in range(300):  # the move takes 0.2 s; it completes once the robot has caught up
                session.engine.tick()
                if client.get(f"/api/commands/{cid}").json()["status"] != "started":
                    break
            status = client.get(f"/api/commands/{cid}").json()
            assert status["status"] == "completed" and status["outcome"]["settled"], status
            eyelid = session.engine.tick().position[desk.channel_index["eyelid_left"]]
            assert eyelid > 0.5  # the 'sleepy' posture's eyelids (1.0), on their way or there

            bad = client.post("/api/commands", json={"type": "fall_asleep", "duration": 99})
            assert bad.status_code == 422 and bad.json()["detail"]["field"].endswith("duration")

            tools = {t["name"]: t for t in client.get("/api/tools").json()["tools"]}
            assert tools["fall_asleep"]["command"] == "fall_asleep" and tools["fall_asleep"]["long_action"]
            assert tools["fall_asleep"]["parameters"]["properties"]["duration"]["maximum"] == 30.0
    finally:
        session.engine.close()


@pytest.fixture()
def udp_json(example_module):
    return example_module("driver", "backend.drivers.udp_json")


def test_driver_example_is_on_the_command_line_and_sends_frames(desk, udp_json):
    import argparse

    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.bind(("127.0.0.1", 0))
    listener.settimeout(10)
    port = listener.getsockname()[1]
    parser = argparse.ArgumentParser()
    add_driver_options(parser)
    assert "--udp-json" in parser.format_help()
    sinks = build_drivers(desk, parser.parse_args(["--udp-json", f"127.0.0.1:{port}", "--sim-servo", "0"]))
    assert [type(s).__name__ for s in sinks] == ["UdpJsonDriver"]
    session = EngineSession.create(desk, rate=50)
    session.engine.add_sink(sinks[0])
    frames = list(session.run_headless(5))
    session.engine.close()
    stats = sinks[0].stats()
    assert stats["errors"] == 0 and stats["delivered"] + stats["dropped"] == 5, stats
    got = [json.loads(listener.recv(65536)) for _ in range(stats["delivered"])]
    listener.close()
    # Headless ticks outrun the driver's 4-frame queue, so it may drop (and count) the oldest frames.
    by_time = {f.t: f for f in frames}
    assert [g["t"] for g in got] == sorted(g["t"] for g in got) and got[-1]["t"] == frames[-1].t
    for g in got:
        expected = by_time[g["t"]].position[desk.channel_index["head_yaw"]]
        assert g["positions"]["head_yaw"] == pytest.approx(expected)


def test_importer_example_reads_its_suffix(desk, example_module, tmp_path):
    example_module("importer", "backend.importers.tsv")
    path = tmp_path / "look.tsv"
    path.write_text("time\thead_yaw\n0\t0\n0.5\t0.3\n1\t0\n")
    assert detect_format(path) == "tsv"
    doc, report = import_clip(path, desk, up="y")
    assert doc["source"]["format"] == "tsv" and [k["v"] for k in doc["tracks"]["head_yaw"]] == [0, 0.3, 0]
    assert "--up/--forward do not apply to TSV columns; ignored" in report["notes"]


def test_panel_example_is_the_shipped_panel_and_listed_once():
    panels = ROOT / "frontend" / "node_editor" / "panels"
    assert (panels / "ProgramInfoPanel.tsx").read_text() == example("panel")
    index = (panels / "index.ts").read_text()
    line = re.search(r"```ts\n(.*?)```", DOC.split("<!-- example: panel -->", 1)[1], re.S).group(1).strip()
    assert index.count(line) == 1
