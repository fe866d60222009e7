"""Issue #18 end to end: three engines and a robot-side bridge as separate processes on loopback Zenoh,
seen and commanded by a Fleet; one engine killed; the bridge brings its robot to rest by itself."""

from __future__ import annotations

import json
import signal
import threading
import time

import numpy as np
import pytest

from backend.client import NuttyError
from backend.engine.embodiment import load_embodiment
from backend.fleet import Fleet
from tests.fleet_processes import NuttyProcess, local_config, loopback, poll
from tests.server_process import free_port

pytestmark = pytest.mark.slow

ROBOTS = ("museum-1", "museum-2", "museum-3")
RATE = 50.0  # Hz: low, so three engines, a bridge and the test share two busy cores comfortably


class Frames:
    """The latest frame of each robot, and each robot's frames from a mark on."""

    def __init__(self):
        self.latest: dict[str, dict] = {}
        self.log: dict[str, list[dict]] = {}
        self.lock = threading.Lock()

    def __call__(self, robot: str, doc: dict, sent: float | None) -> None:
        with self.lock:
            self.latest[robot] = doc
            self.log.setdefault(robot, []).append(doc)

    def mouth(self, robot: str) -> str | None:
        with self.lock:
            doc = self.latest.get(robot)
        return doc["dofs"]["mouth"]["option"] if doc else None


def test_three_engines_a_fleet_and_a_bridge(tmp_path):
    emb = load_embodiment("nutty_desk")
    config = local_config(tmp_path)
    hub = loopback()  # this test's own session is the router the others connect to
    fleet = Fleet(mode="router", listen=[hub], config=config, timeout=10.0)
    common = ("--zenoh-config", config, "--zenoh-connect", hub)
    engines = {
        rid: NuttyProcess(
            "serve",
            "--port",
            str(free_port()),
            "--no-previz",
            "--rate",
            f"{RATE:g}",
            "--zenoh",
            "--robot-id",
            rid,
            "--zenoh-listen",
            loopback(),
            *common,
        )
        for rid in ROBOTS
    }
    recording = tmp_path / "museum-3.jsonl"
    bridge = NuttyProcess(
        "bridge",
        "--zenoh",
        "--robot-id",
        "museum-3",
        "--robot",
        "nutty_desk",
        "--driver",
        "record",
        "--record",
        str(recording),
        "--timeout",
        "0.3",
        "--report",
        "1",
        "--wait",
        "150",
        *common,
    )
    frames = Frames()
    subscriber = None
    try:
        # The fleet sees all three (liveliness).
        live = fleet.wait_for(set(ROBOTS), timeout=150)
        assert fleet.robots("museum-*") == list(ROBOTS) and live == list(ROBOTS)
        subscriber = fleet.frames("museum-*", frames)
        poll(lambda: all(frames.mouth(r) == "neutral" for r in ROBOTS), 30, "frames from every engine")
        assert bridge.wait_output("following robot 'museum-3'", 60), bridge.output

        # One robot: the command takes effect in its frames, and only there.
        ack = fleet["museum-1"].face("surprised")
        assert ack["status"] == "completed" and ack["result"]["expression"] == "surprised"
        poll(lambda: frames.mouth("museum-1") == "surprised", 10, "museum-1 looks surprised")
        time.sleep(0.5)  # several more frames of every robot
        assert frames.mouth("museum-2") == frames.mouth("museum-3") == "neutral"

        # A bad command is refused as REST refuses it, naming the field; nothing changes.
        with pytest.raises(NuttyError) as refused:
            fleet["museum-2"].command("set_face", expression=["not", "a", "name"])
        assert refused.value.status == 422 and refused.value.detail["field"] == "expression"

        # A pattern: every matching robot acks under one id and shows it.
        acks = fleet.group("museum-*").face("smile")
        assert sorted(acks) == list(ROBOTS)
        assert len({a["id"] for a in acks.values()}) == 1 and all(
            a["status"] == "completed" for a in acks.values()
        )
        poll(lambda: all(frames.mouth(r) == "smile" for r in ROBOTS), 10, "every robot smiles")
        assert fleet.send("nobody-*", {"type": "reset"}) == {}

        # museum-3 is followed by the bridge; it gets killed mid-motion (no park): its liveliness goes,
        # and the bridge takes the robot to rest by itself.
        poll(lambda: bridge.output.count(" live: ") >= 2, 30, "the bridge reports live frames")
        rested = bridge.output.count("holding it there")
        with fleet.watch("museum-*") as watch:
            engines["museum-3"].proc.kill()
            engines["museum-3"].proc.wait(10)
            poll(lambda: "museum-3" not in fleet.robots(), 15, "museum-3's liveliness vanishes")
            seen = [e for e in iter(lambda: watch.get(timeout=1.0), None)]
        assert {"type": "robot", "event": "vanished", "robot": "museum-3"} in seen
        assert fleet.robots() == ["museum-1", "museum-2"]
        poll(lambda: bridge.output.count("holding it there") > rested, 30, "the bridge rests the robot")
        bridge.signal(signal.SIGTERM)
        assert bridge.wait_exit(20) == 0, bridge.output
        summary = json.loads(bridge.output.split("nutty bridge: summary ", 1)[1].splitlines()[0])
        assert summary["timeouts"] >= 1 and summary["received"] > 50 and summary["mode"] == "at rest"
        _check_fade_to_rest(emb, recording, summary)

        # The others park on SIGTERM, and the park's frames go out on Zenoh up to the rest pose.
        for rid in ("museum-1", "museum-2"):
            engines[rid].signal(signal.SIGTERM)
        for rid in ("museum-1", "museum-2"):
            assert engines[rid].wait_exit(20) == 0, engines[rid].output
            last = frames.latest[rid]["dofs"]
            for name in emb.continuous_names:
                assert (
                    last[name]["position"] == emb.rest[emb.channel_index[name]]
                    and last[name]["velocity"] == 0.0
                )
        poll(lambda: fleet.robots() == [], 15, "no robot left")
    finally:
        if subscriber is not None:
            subscriber.undeclare()
        for proc in (bridge, *engines.values()):
            proc.close()
        fleet.close()


def _check_fade_to_rest(emb, recording, summary) -> None:
    """The bridge's output: every step within the robot's limits (finite differences at the tick), and
    the last frames exactly the rest pose, standing still."""
    from test_safe_swaps import recorded_positions, worst_ratios

    rows = [json.loads(line) for line in recording.read_text().splitlines()]
    names = emb.continuous_names
    idx = [emb.channel_index[n] for n in names]
    pos = np.array([[r["dofs"][n]["position"] for n in names] for r in rows])
    # One frame per tick, whatever was lost on the way (the net bridges a gap tick by tick), so the
    # differences are taken at the tick everywhere: channels and the joints they compose to.
    assert all(abs(r["dt"] - 1 / RATE) < 1e-12 for r in rows)
    r = worst_ratios(emb, recorded_positions(emb, rows), RATE)
    slack = 1 + 1e-6  # floating-point rounding only
    assert r["v"] <= slack and r["a"] <= slack and r["j"] <= slack and r["outside"] <= 1e-12, r
    assert np.array_equal(pos[-1], emb.rest[idx]) and np.array_equal(pos[-2], emb.rest[idx])
    moved = np.max(np.abs(pos - emb.rest[idx]), axis=1)
    assert moved.max() > 1e-3, "the robot never left rest: nothing was faded"
    assert summary["sent"] == len(rows)


def test_the_readme_recipe_runs_as_written(tmp_path):
    """README's three terminals: an engine, a bridge, then the fleet lists and commands it. Run as written,
    but on a free port, another HTTP port and with multicast scouting off (no other test's peers)."""
    import re
    import shlex
    import subprocess
    import sys
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = re.search(r"## Many robots, many machines \(Zenoh\).*?```sh\n(.*?)```", readme, re.S).group(1)
    lines = [shlex.split(line) for line in block.strip().splitlines()]
    assert [line[:2] for line in lines] == [
        ["nutty", "serve"],
        ["nutty", "bridge"],
        ["nutty", "fleet"],
        ["nutty", "fleet"],
    ]
    endpoint, isolated = loopback(), ["--zenoh-config", local_config(tmp_path)]

    def as_here(line: list[str]) -> list[str]:
        args = [endpoint if a == "tcp/127.0.0.1:7447" else a for a in line[1:]] + isolated
        return args + (["--port", str(free_port())] if args[0] == "serve" else [])

    engine, bridge = NuttyProcess(*as_here(lines[0])), NuttyProcess(*as_here(lines[1]))
    try:
        assert bridge.wait_output("following robot 'desk-1'", 150), engine.output + bridge.output
        run = [
            subprocess.run(
                [sys.executable, "-m", "backend.cli", *as_here(line)],
                capture_output=True,
                text=True,
                timeout=60,
            )
            for line in lines[2:]
        ]
        assert run[0].returncode == 0 and run[0].stdout.split() == ["desk-1"], run[0].stderr
        assert run[1].returncode == 0, run[1].stdout + run[1].stderr
        ack = json.loads(run[1].stdout)["desk-1"]
        assert ack["type"] == "ack" and ack["status"] == "started"
        bridge.signal(signal.SIGTERM)
        assert bridge.wait_exit(20) == 0, bridge.output
        engine.signal(signal.SIGTERM)
        assert engine.wait_exit(20) == 0, engine.output
    finally:
        bridge.close()
        engine.close()
