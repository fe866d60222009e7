"""The AI tools through the API in process: generated from the running robot, program and library;
valid JSON Schema in every dialect; every tool executes; overlap policies; tools_changed; get_status."""

from __future__ import annotations

import json
import shutil
import time

import pytest
from fastapi.testclient import TestClient
from jsonschema import Draft202012Validator

from backend.api import create_app
from backend.commands.serve import builtin_idle
from backend.engine.embodiment import load_embodiment, robots_dir
from backend.session import EngineSession
from tests.tool_calls import example_arguments

INTERACTIVE = robots_dir() / "nutty_desk" / "programs" / "interactive.json"
NEW_CLIP = {
    "format": "nutty-clip/1",
    "name": "peek",
    "description": "A quick peek to the left and back.",
    "relative": True,
    "tracks": {"head_yaw": [{"t": 0, "v": 0}, {"t": 0.4, "v": 0.3}, {"t": 0.8, "v": 0}]},
}


@pytest.fixture()
def robot(tmp_path):
    """A copy of the default robot, so saving clips never touches the repository."""
    folder = tmp_path / "nutty_desk"
    shutil.copytree(robots_dir() / "nutty_desk", folder)
    return folder


@pytest.fixture()
def session(robot):
    s = EngineSession.create(load_embodiment(robot), rate=100, program_text=INTERACTIVE.read_text())
    s.engine.start()
    yield s
    s.engine.close()


@pytest.fixture()
def client(session):
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


def call(client, name, **arguments):
    r = client.post(f"/api/tools/{name}", json=arguments)
    assert r.status_code == 200, r.text
    return r.json()


def test_tools_come_from_the_robot_program_and_library(client, robot):
    doc = client.get("/api/tools").json()
    assert (
        doc["format"] == "nutty-tools/1" and doc["robot"] == "nutty_desk" and doc["program"] == "interactive"
    )
    tools = {t["name"]: t for t in doc["tools"]}
    assert list(tools) == [
        "play_behaviour",
        "play_clip",
        "set_posture",
        "look_at",
        "set_emotion",
        "set_inputs",
        "say",
        "play_sound",
        "set_led",
        "set_face",
        "set_layer",
        "stop",
        "cancel",
        "get_status",
        "get_frame",
    ]
    clips = sorted(p.stem for p in (robot / "clips").glob("*.json"))
    clip = tools["play_clip"]["parameters"]["properties"]["clip"]
    assert clip["enum"] == clips
    assert (
        "- nod (1.25 s): A friendly 'yes'" in clip["description"]
    )  # each clip with its description and duration
    posture = tools["set_posture"]["parameters"]["properties"]["posture"]
    assert posture["enum"] == ["curious", "happy", "neutral", "sad", "sleepy", "surprised"]
    assert "- sleepy: Drowsy:" in posture["description"]
    assert tools["set_face"]["parameters"]["properties"]["expression"]["enum"][:3] == [
        "neutral",
        "smile",
        "grin",
    ]
    assert "x forward, y to the robot's left, z up" in tools["look_at"]["description"]
    assert "yaw -3.8..3.8 rad" in tools["look_at"]["description"]
    emotion = tools["set_emotion"]["parameters"]["properties"]
    assert (emotion["valence"]["minimum"], emotion["valence"]["maximum"]) == (-1.0, 1.0)
    assert set(tools["set_inputs"]["parameters"]["properties"]["values"]["properties"]) == {
        "gaze_target",
        "valence",
        "arousal",
    }
    assert tools["play_clip"]["long_action"] and "wait" in tools["play_clip"]["parameters"]["properties"]
    assert tools["stop"]["command"] == "stop_all" and tools["get_status"]["command"] is None
    assert [c["name"] for c in doc["library"]["clips"]] == clips


@pytest.mark.parametrize("fmt", ["plain", "openai", "anthropic"])
def test_every_dialect_is_valid_json_schema(client, fmt):
    body = client.get(f"/api/tools?format={fmt}").json()
    if fmt == "openai":
        assert all(
            t["type"] == "function" and set(t["function"]) == {"name", "description", "parameters"}
            for t in body
        )
        schemas = {t["function"]["name"]: t["function"]["parameters"] for t in body}
    elif fmt == "anthropic":
        assert all(set(t) == {"name", "description", "input_schema"} for t in body)
        schemas = {t["name"]: t["input_schema"] for t in body}
    else:
        schemas = {t["name"]: t["parameters"] for t in body["tools"]}
    assert len(schemas) == 15
    for name, schema in schemas.items():
        assert schema["type"] == "object", name
        Draft202012Validator.check_schema(schema)
        Draft202012Validator(schema).validate(example_arguments(schema))  # a generated call fits its schema
    assert client.get("/api/tools?format=yaml").json()["detail"]["field"] == "format"


def test_a_generated_call_of_every_tool_executes(client):
    for tool in client.get("/api/tools").json()["tools"]:
        arguments = example_arguments(tool["parameters"])
        r = client.post(f"/api/tools/{tool['name']}", json=arguments)
        if tool["name"] == "cancel":  # the generated id names no command: a clear error naming the field
            assert r.status_code == 404 and r.json()["detail"]["field"] == "target", r.text
            continue
        assert r.status_code == 200, (tool["name"], arguments, r.text)
        assert r.json()["tool"] == tool["name"]


def test_bad_arguments_name_the_field_and_change_nothing(client, session):
    before = session.inputs()
    cases = [
        ("play_clip", {"clip": "moonwalk"}, 422, "clip"),
        ("play_clip", {"clip": "nod", "speed": 50}, 422, "speed"),
        ("play_clip", {"clip": "nod", "wait": True, "timeout": 999}, 422, "timeout"),
        ("set_emotion", {"valence": 3, "arousal": 0}, 422, "valence"),
        ("set_inputs", {"values": {"valence": 2}}, 422, "valence"),
        ("look_at", {"target": [1, 2]}, 422, "target"),
        ("set_posture", {"posture": "happy", "bogus": 1}, 422, "bogus"),
        ("stop", {"fade": 1.0}, 422, "fade"),
        ("get_status", {"id": "nobody"}, 404, "id"),
        ("fly", {}, 404, "name"),
    ]
    for name, arguments, status, field in cases:
        r = client.post(f"/api/tools/{name}", json=arguments)
        assert r.status_code == status and r.json()["detail"]["field"].split(".")[0] == field, (name, r.text)
    assert session.inputs() == before


def test_wait_poll_and_cancel_a_long_action(client):
    done = call(client, "play_clip", clip="nod", wait=True, timeout=20)
    assert (done["status"], done["waited"], done["timed_out"]) == ("completed", True, False)
    running = call(client, "play_clip", clip="sad")
    assert running["status"] == "started" and not running["waited"]
    status = call(client, "get_status", id=running["id"])
    assert status["command"]["status"] == "started"
    assert status["playing"][0]["clip"] == "sad" and status["playing"][0]["command_id"] == running["id"]
    assert status["playing"][0]["layers"] == ["gesture"]
    cancel = call(client, "cancel", target=running["id"])
    assert cancel["result"] == {"target": running["id"], "status": "cancelled"}
    assert (
        call(client, "get_status", id=running["id"], wait=True, timeout=5)["command"]["status"] == "cancelled"
    )
    short = call(client, "set_posture", posture="curious", duration=5.0, wait=True, timeout=0.3)
    assert short["timed_out"] and short["status"] == "started"  # the move goes on after the wait's timeout


def test_if_busy_replace_queue_and_reject(client):
    with client.websocket_connect("/ws/control") as ws:
        first = call(client, "play_clip", clip="sad")
        rejected = client.post("/api/tools/play_clip", json={"clip": "nod", "if_busy": "reject"})
        assert rejected.status_code == 409
        detail = rejected.json()["detail"]
        assert detail["code"] == "busy" and detail["field"] == "if_busy"
        assert "layer 'gesture'" in detail["message"] and first["id"] in detail["message"]
        queued = call(client, "play_clip", clip="nod", if_busy="queue")
        dropped = call(client, "play_clip", clip="wave", if_busy="queue")
        assert queued["status"] == dropped["status"] == "queued"
        assert client.get(f"/api/commands/{queued['id']}").json()["status"] == "queued"
        call(client, "cancel", target=dropped["id"])  # cancelled while it waits: it never starts
        call(client, "cancel", target=first["id"])  # the queued clip starts now
        assert (
            call(client, "get_status", id=queued["id"], wait=True, timeout=20)["command"]["status"]
            == "completed"
        )
        replaced = call(client, "play_clip", clip="sad")
        call(client, "play_clip", clip="nod")  # replace (the default) crossfades: the first is cancelled
        events = {}
        deadline = time.time() + 20
        while time.time() < deadline and events.get(replaced["id"], [])[-1:] != ["cancelled"]:
            msg = ws.receive_json()
            if msg.get("type") == "event":
                events.setdefault(msg["id"], []).append(msg["event"])
    assert events[first["id"]] == ["started", "cancelled"]
    assert events[queued["id"]] == ["started", "completed"]  # `started` only when its turn came
    assert events[dropped["id"]] == ["cancelled"]
    assert events[replaced["id"]] == ["started", "cancelled"]


def next_tools_changed(ws) -> dict:
    while True:
        msg = ws.receive_json()
        if msg.get("event") == "tools_changed":
            return msg


def test_tools_change_with_the_library_and_program(client, session):
    with client.websocket_connect("/ws/control") as ws:
        revision = client.get("/api/tools").json()["revision"]
        assert client.put("/api/clips/peek", json=NEW_CLIP).status_code == 200
        msg = ws.receive_json()  # the first message: nothing else happened meanwhile
        assert msg["type"] == "event" and msg["event"] == "tools_changed" and msg["id"] is None
        assert msg["revision"] != revision and "play_clip" in msg["tools"]
        doc = client.get("/api/tools").json()
        assert doc["revision"] == msg["revision"]
        clip = next(t for t in doc["tools"] if t["name"] == "play_clip")["parameters"]["properties"]["clip"]
        assert "peek" in clip["enum"] and "- peek (0.8 s): A quick peek" in clip["description"]
        assert call(client, "play_clip", clip="peek", wait=True, timeout=20)["status"] == "completed"
        assert client.put("/api/program", json=builtin_idle("nutty_desk")).status_code == 200
        msg = next_tools_changed(ws)
        # The built-in idle program has no clip player and no gaze input: no such tools, and of the
        # behaviours only sleepy (a posture, the mood, speech and a sound) is offered.
        assert msg["tools"] == [
            "play_behaviour",
            "set_posture",
            "set_emotion",
            "set_inputs",
            "say",
            "play_sound",
            "set_led",
            "set_face",
            "set_layer",
            "stop",
            "cancel",
            "get_status",
            "get_frame",
        ]
    assert (
        client.post("/api/tools/play_clip", json={"clip": "nod"}).json()["detail"]["code"] == "unknown_tool"
    )
    tools = {t["name"]: t for t in client.get("/api/tools").json()["tools"]}
    assert tools["play_behaviour"]["parameters"]["properties"]["behaviour"]["enum"] == ["sleepy"]


def test_get_status_reports_layers_gaze_mood_and_health(client):
    call(client, "look_at", target=[0.8, 0.3, 0.4])
    call(client, "set_emotion", valence=0.5, arousal=-0.25)
    call(client, "set_layer", layer="wander", active=False, fade=0.0)
    move = call(client, "set_posture", posture="happy", duration=3.0)
    status = call(client, "get_status")
    assert status["gaze"]["target"] == [0.8, 0.3, 0.4] and "x forward" in status["gaze"]["units"]
    assert status["mood"] == {"valence": 0.5, "arousal": -0.25}
    assert status["posture"][0]["move"]["posture"] == "happy"
    assert status["posture"][0]["move"]["command_id"] == move["id"]
    wander = next(s for s in status["layers"]["mix"] if s["name"] == "wander")
    assert wander["active"] is False
    assert status["health"]["running"] and status["health"]["safety"]["enabled"]
    json.dumps(status)  # plain JSON throughout
