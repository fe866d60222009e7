"""Playing behaviours: items become commands at their ticks through the program; one started and one
terminal event per behaviour and an event per item; cancel, stop_all, if_busy; the robot's limits hold;
the AI tool's list follows the library."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend import control
from backend.api import create_app
from backend.engine.embodiment import load_embodiment
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
DESK = ROOT / "robots" / "nutty_desk"
INTERACTIVE = (DESK / "programs" / "interactive.json").read_text()
TERMINAL = ("completed", "cancelled", "failed")


def fresh(desk) -> EngineSession:
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE)
    session.engine.run_ticks(20)
    session.notes.clear()
    return session


def behaviour_notes(session, cid):
    return [n for n in session.notes if n.get("command_id") == cid]


def run_until_terminal(session, cid, seconds=15.0):
    frames = []
    for _ in range(int(seconds * session.engine.rate)):
        frames.append(session.engine.tick())
        if any(n["event"] in TERMINAL for n in behaviour_notes(session, cid)):
            break
    return frames


def within_limits(desk, frames):
    """Every delivered frame within the robot's velocity limits (the net's guarantee, checked here)."""
    vel = np.array([f.velocity for f in frames])[:, desk.continuous_mask]
    assert np.all(np.abs(vel) <= desk.vel_limit[desk.continuous_mask] * (1 + 1e-6) + 1e-9)


def test_one_started_one_terminal_and_an_event_per_item(desk):
    session = fresh(desk)
    ack = session.execute(
        {"type": "play_behaviour", "behaviour": "greet", "id": "g1", "params": {"name": "Ana"}}
    )
    assert ack == {"behaviour": "greet", "duration": pytest.approx(3.2, abs=0.01), "items": 6}
    frames = run_until_terminal(session, "g1")
    notes = behaviour_notes(session, "g1")
    events = [n["event"] for n in notes]
    assert events.count("started") == 1 and events[0] == "started"
    assert [e for e in events if e in TERMINAL] == ["completed"] and events[-1] == "completed"
    items = [(n["item"], n["state"]) for n in notes if n["event"] == "item"]
    ids = ["look", "wave", "smile", "warm_eyes", "hello", "happy"]
    assert sorted({i for i, _ in items}) == sorted(ids)
    for i in ids:  # each item starts once and ends once, in that order
        assert [s for j, s in items if j == i] == ["started", "completed"], i
    started = {n["item"]: n["t"] for n in notes if n["event"] == "item" and n["state"] == "started"}
    assert started["hello"] == pytest.approx(1.05, abs=0.011)  # on the wave's beat
    said = [(f.t, e.payload["text"]) for f in frames for e in f.events if e.kind == "say"]
    assert [text for _, text in said] == ["Hello Ana!"]
    within_limits(desk, frames)


def test_cancel_stops_what_it_started(desk):
    session = fresh(desk)
    session.execute({"type": "play_behaviour", "behaviour": "celebrate", "id": "c1"})
    session.engine.run_ticks(100)  # 1 s: the clip and the speech are under way, the nod is not
    player = session.engine.apu.block("gesture")
    assert player.state.current is not None and player.state.env_target == 1.0
    control.cancel_command(session, "play_behaviour", "c1")
    session.engine.run_ticks(80)
    notes = behaviour_notes(session, "c1")
    assert [n["event"] for n in notes if n["event"] in TERMINAL] == ["cancelled"]
    cancelled = {n["item"] for n in notes if n["event"] == "item" and n["state"] == "cancelled"}
    assert {"joy", "cheer"} <= cancelled
    assert not any(n["event"] == "item" and n["item"] == "nod" for n in notes)  # never started
    assert session.engine.apu.block("gesture").state.env_target == 0.0  # the clip fades out
    assert session.engine.apu.block("voice").state.current is None  # the speech stopped
    assert not np.any(session.engine._override_mask)  # the LEDs and face it held are released


def test_stop_all_and_reset_end_behaviours(desk):
    session = fresh(desk)
    session.execute({"type": "play_behaviour", "behaviour": "sleepy", "id": "s1"})
    session.engine.run_ticks(50)
    session.execute({"type": "stop_all"})
    session.engine.run_ticks(5)
    assert [n["event"] for n in behaviour_notes(session, "s1") if n["event"] in TERMINAL] == ["cancelled"]
    session.execute({"type": "play_behaviour", "behaviour": "think", "id": "t1"})
    session.engine.run_ticks(30)
    session.execute({"type": "reset", "fade": 0.2})
    session.engine.run_ticks(5)
    assert [n["event"] for n in behaviour_notes(session, "t1") if n["event"] in TERMINAL] == ["cancelled"]
    assert session.behaviours.current is None


def test_if_busy_reject_queue_and_replace(desk):
    session = fresh(desk)
    session.execute({"type": "play_behaviour", "behaviour": "greet", "id": "a"})
    session.engine.run_ticks(10)
    with pytest.raises(control.CommandError) as refused:
        session.execute({"type": "play_behaviour", "behaviour": "think", "id": "b", "if_busy": "reject"})
    assert refused.value.code == "busy" and refused.value.extra["playing"] == "a"
    queued = session.execute(
        {"type": "play_behaviour", "behaviour": "celebrate", "id": "c", "if_busy": "queue"}
    )
    assert queued["queued"] is True
    run_until_terminal(session, "a")
    session.engine.run_ticks(3)
    assert [n["event"] for n in behaviour_notes(session, "c")][:1] == ["started"]  # after a completed
    session.execute({"type": "play_behaviour", "behaviour": "think", "id": "d"})  # replace (default)
    session.engine.run_ticks(3)
    assert [n["event"] for n in behaviour_notes(session, "c") if n["event"] in TERMINAL] == ["cancelled"]
    assert behaviour_notes(session, "d")[0]["event"] == "started"


def test_a_refused_item_fails_the_behaviour_and_stops_the_rest(desk):
    session = fresh(desk)
    doc = {
        "tracks": [
            {
                "name": "t",
                "items": [
                    {"id": "nod", "kind": "play_clip", "clip": "nod"},
                    {
                        "id": "elsewhere",
                        "kind": "play_clip",
                        "clip": "wave",
                        "layer": "no_such_layer",
                        "start": 0.3,
                    },
                ],
            }
        ]
    }
    session.execute({"type": "play_behaviour", "behaviour": "draft", "document": doc, "id": "f1"})
    run_until_terminal(session, "f1", 3.0)
    notes = behaviour_notes(session, "f1")
    failed = [n for n in notes if n["event"] == "failed"]
    assert len(failed) == 1 and "elsewhere" in failed[0]["error"] and "no_such_layer" in failed[0]["error"]
    assert ("nod", "cancelled") in [(n.get("item"), n.get("state")) for n in notes]


def test_a_behaviour_the_program_cannot_play_is_refused_item_by_item(desk):
    session = fresh(desk)
    with pytest.raises(control.CommandError) as bad:
        session.execute({"type": "play_behaviour", "behaviour": "greet", "params": {"name": 7}})
    assert bad.value.code == "invalid_behaviour" and bad.value.extra["errors"][0]["field"] == "name"
    with pytest.raises(control.CommandError) as missing:
        session.execute({"type": "play_behaviour", "behaviour": "hug"})
    assert missing.value.code == "not_found" and "greet" in str(missing.value)
    assert session.behaviours.current is None and not session.behaviours.queue


def test_ramps_reach_their_value_and_look_at_follows_an_input(desk):
    program = json.loads(INTERACTIVE)
    program["inputs"].append({"name": "person", "type": "vec3", "default": [1.0, 0.0, 0.35]})
    session = EngineSession.create(desk, rate=100, program=program)
    session.engine.run_ticks(10)
    doc = {
        "tracks": [
            {
                "name": "t",
                "items": [
                    {"id": "calm", "kind": "ramp", "input": "arousal", "to": -0.8, "duration": 1.0},
                    {"id": "watch", "kind": "look_at", "target": "person", "duration": 1.5},
                ],
            }
        ]
    }
    session.execute({"type": "play_behaviour", "behaviour": "draft", "document": doc, "id": "r"})
    session.engine.run_ticks(50)
    assert -0.8 < session.engine.ctx.inputs["arousal"] < 0.0  # half way, smoothly
    session.engine.call(lambda: session.engine.ctx.inputs.__setitem__("person", [1.0, 0.6, 0.4]))
    session.engine.run_ticks(5)
    assert session.engine.ctx.inputs["gaze_target"] == [1.0, 0.6, 0.4]  # the gaze follows the person
    run_until_terminal(session, "r")
    assert session.engine.ctx.inputs["arousal"] == pytest.approx(-0.8)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    import shutil

    robot = tmp_path_factory.mktemp("robot") / "nutty_desk"
    shutil.copytree(DESK, robot)
    session = EngineSession.create(load_embodiment(robot), rate=100, program_text=INTERACTIVE)
    session.engine.start()
    with TestClient(create_app(session, frontend_dir=None)) as client:
        yield client
    session.engine.close()


def control_messages(ws, cid, timeout=15.0):
    out, end = [], time.time() + timeout
    while time.time() < end:
        msg = ws.receive_json()
        out.append(msg)
        if msg.get("id") == cid and msg.get("event") in TERMINAL:
            return out
    raise AssertionError("no terminal event")


def test_over_the_control_socket_the_item_commands_stay_inside_the_behaviour(server):
    with server.websocket_connect("/ws/control") as ws:
        ws.send_json({"type": "play_behaviour", "behaviour": "think", "id": "w1"})
        messages = control_messages(ws, "w1")
    mine = [m for m in messages if m.get("id") == "w1"]
    acks = [m for m in mine if m["type"] == "ack"]  # its `started` event may overtake the ack
    assert len(acks) == 1 and acks[0]["status"] == "started" and acks[0]["result"]["behaviour"] == "think"
    events = [m["event"] for m in mine if m["type"] == "event"]
    assert events.count("started") == 1 and events[-1] == "completed" and events.count("completed") == 1
    assert {m["item"] for m in mine if m.get("event") == "item"} == {
        "look_up",
        "calm",
        "ponder",
        "thinking_eyes",
        "words",
        "hum",
        "done",
        "back_to_neutral",
    }
    assert mine[-1]["command"] == "play_behaviour" and mine[-1]["outcome"]["settled"] in (True, False)
    assert not [m for m in messages if ":" in str(m.get("id"))]  # no item command leaks out as a command
    assert server.get("/api/commands/w1").json()["status"] == "completed"


def test_cancel_by_id_and_busy_over_rest(server):
    r = server.post("/api/commands", json={"type": "play_behaviour", "behaviour": "sleepy", "id": "z1"})
    assert r.status_code == 200 and r.json()["status"] == "started"
    r = server.post(
        "/api/commands", json={"type": "play_behaviour", "behaviour": "greet", "if_busy": "reject"}
    )
    assert r.status_code == 409 and r.json()["detail"]["code"] == "busy"
    assert server.delete("/api/commands/z1").json()["status"] == "cancelled"


def test_the_ai_tool_lists_the_behaviours_and_follows_the_library(server):
    def tool():
        tools = server.get("/api/tools").json()["tools"]
        return next(t for t in tools if t["name"] == "play_behaviour")

    first = tool()
    assert first["parameters"]["properties"]["behaviour"]["enum"] == ["celebrate", "greet", "sleepy", "think"]
    params = first["parameters"]["properties"]["params"]["properties"]
    assert params["name"]["type"] == "string" and "greet" in params["name"]["description"]
    assert "document" not in first["parameters"]["properties"]
    assert "Greet a person" in first["parameters"]["properties"]["behaviour"]["description"]
    doc = {
        "description": "A quick nod.",
        "tracks": [{"name": "t", "items": [{"id": "n", "kind": "play_clip", "clip": "nod"}]}],
    }
    assert server.put("/api/behaviours/quick_yes", json=doc).status_code == 200
    assert "quick_yes" in tool()["parameters"]["properties"]["behaviour"]["enum"]
    answer = server.post(
        "/api/tools/play_behaviour", json={"behaviour": "quick_yes", "wait": True, "timeout": 10}
    )
    assert answer.status_code == 200 and answer.json()["status"] == "completed", answer.text
    assert server.delete("/api/behaviours/quick_yes").status_code == 200
    assert "quick_yes" not in tool()["parameters"]["properties"]["behaviour"]["enum"]


def test_saving_reports_every_error_on_its_item(server):
    doc = json.loads((DESK / "behaviours" / "greet.json").read_text())
    doc["tracks"][1]["items"][0]["clip"] = "wav"
    doc["tracks"][3]["items"][0]["expression"] = "smirk"
    r = server.put("/api/behaviours/broken", json=doc)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["code"] == "invalid_behaviour"
    assert {(e["item"], e["field"]) for e in detail["errors"]} == {("wave", "clip"), ("smile", "expression")}
    assert server.get("/api/behaviours/broken").status_code == 404  # nothing was stored
