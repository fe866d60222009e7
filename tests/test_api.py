"""The HTTP and WebSocket API through TestClient: every route, error codes, token on/off."""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from backend.api import create_app
from backend.commands.serve import builtin_idle
from backend.session import EngineSession


@pytest.fixture()
def session(desk):
    s = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    s.engine.start()
    yield s
    s.engine.close()


@pytest.fixture()
def client(session, tmp_path):
    session.library.folder = tmp_path  # never write into the repository's robot folder
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


def test_robot_blocks_and_schemas(client):
    robot = client.get("/api/robot").json()
    assert robot["name"] == "nutty_desk" and robot["dimensions"]["audible"] == 2
    assert "<robot" in client.get("/api/robot/urdf").text
    blocks = {b["type"]: b for b in client.get("/api/blocks").json()}
    assert {"sine", "layer_mixer", "nmf_stage2", "output"} <= set(blocks)
    assert blocks["sine"]["params_schema"]["properties"]["amplitude"]["maximum"] == 10.0
    ports = client.post(
        "/api/blocks/layer_mixer/ports", json={"params": {"layers": [{"name": "a"}, {"name": "b"}]}}
    )
    assert list(ports.json()["inputs"]) == ["a", "b", "a_weight", "b_weight"]
    assert client.post("/api/blocks/nope/ports", json={}).status_code == 404
    assert client.get("/api/schema/program").json()["title"] == "Nutty Animation Program"
    assert "play_clip" in json.dumps(client.get("/api/schema/commands").json())


def test_get_validate_and_put_program(client, session):
    current = client.get("/api/program").json()
    assert current["level"] == 3 and current["program"]["name"] == "built-in idle"
    doc = current["program"]
    ok = client.post("/api/program/validate", json=doc).json()
    assert ok["valid"] is True
    broken = json.loads(json.dumps(doc))
    next(n for n in broken["nodes"] if n["id"] == "breathe")["type"] = "sinus"
    broken["edges"].append({"from": {"node": "nope", "port": "out"}, "to": {"node": "mix", "port": "base"}})
    report = client.post("/api/program/validate", json=broken).json()
    assert report["valid"] is False and {e["code"] for e in report["errors"]} >= {
        "unknown_block_type",
        "unknown_node",
    }
    apu_before = session.engine.apu
    r = client.put("/api/program", json=broken)
    assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_program"
    assert len(r.json()["detail"]["report"]["errors"]) >= 2
    assert session.engine.apu is apu_before  # nothing changed
    next(n for n in doc["nodes"] if n["id"] == "breathe")["params"]["amplitude"] = 0.08
    r = client.put("/api/program", json=doc)
    assert r.status_code == 200 and "breathe" in r.json()["kept"]
    assert (
        client.put(
            "/api/program", content=b"{not json", headers={"content-type": "application/json"}
        ).status_code
        == 400
    )
    assert client.put("/api/program", content=b"{not json").status_code == 415  # JSON must be declared


def test_patch_params_live(client, session):
    block = session.engine.apu.block("breathe")
    r = client.patch("/api/program/nodes/breathe/params", json={"amplitude": 0.02})
    assert r.status_code == 200 and r.json()["params"]["amplitude"] == 0.02
    assert session.engine.apu.block("breathe") is block and block.params.amplitude == 0.02
    r = client.patch("/api/program/nodes/breathe/params", json={"amplitude": 99})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_param"
    assert client.patch("/api/program/nodes/ghost/params", json={}).status_code == 404
    r = client.patch(
        "/api/program/nodes/breathe/params",
        content=b'{"amplitude": NaN}',
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 400


def test_library_routes(client):
    assert client.get("/api/programs").json() == []
    prog = client.get("/api/program").json()["program"]
    assert client.put("/api/programs/mine", json=prog).json() == {"saved": "mine"}
    assert client.get("/api/programs").json() == ["mine"]
    assert client.get("/api/programs/mine").json()["name"] == "built-in idle"
    bad = dict(prog, nodes=[])
    assert client.put("/api/programs/bad", json=bad).status_code == 422
    assert client.get("/api/programs/..%2Fetc").status_code in (404, 422)
    assert client.delete("/api/programs/mine").json() == {"deleted": "mine"}
    assert client.delete("/api/programs/mine").status_code == 404
    assert "happy" in client.get("/api/postures").json()  # embodiment.yaml postures are listed
    assert client.get("/api/postures/happy").json()["values"]["mouth"] == "smile"
    assert client.put("/api/clips/c1", json={"name": "c1"}).status_code in (200, 422)
    assert client.get("/api/clips/none").status_code == 404


def test_inputs_and_commands(client, session):
    inputs = client.get("/api/inputs").json()
    assert inputs["values"]["arousal"] == 0.0 and inputs["declarations"][0]["name"] == "arousal"
    assert client.put("/api/inputs/arousal", json={"value": 0.5}).json()["value"] == 0.5
    r = client.put("/api/inputs/arousal", json={"value": 3})
    assert r.status_code == 422 and "outside" in r.json()["detail"]["message"]
    assert client.put("/api/inputs/nope", json={"value": 1}).status_code == 422
    r = client.post("/api/commands", json={"type": "set_led", "colour": [1, 0, 0]})
    assert r.status_code == 200 and r.json()["status"] == "completed"
    cid = r.json()["id"]
    assert client.get(f"/api/commands/{cid}").json()["type"] == "set_led"
    r = client.post("/api/commands", json={"type": "set_led", "colour": [2, 0, 0]})
    assert r.status_code == 422 and r.json()["detail"]["field"] == "colour"
    r = client.post("/api/commands", json={"type": "dance"})
    assert r.status_code == 422 and r.json()["detail"]["field"] == "type"
    r = client.post("/api/commands", json={"type": "play_clip", "clip": "wave", "layer": "gesture"})
    assert r.status_code == 404 and "no clip player" in r.json()["detail"]["message"]
    r = client.post("/api/commands", json={"type": "play_sound", "sound": "moo"})
    assert r.status_code == 422 and "unknown sound" in r.json()["detail"]["message"]
    assert client.post("/api/commands", json={"type": "say", "text": "hi"}).json()["status"] == "completed"
    assert (
        client.post("/api/commands", json={"type": "set_layer", "layer": "idle", "active": False}).status_code
        == 200
    )
    assert client.post("/api/commands", json={"type": "reset"}).status_code == 200
    assert client.post("/api/commands", json={"type": "stop_all"}).status_code == 200
    assert client.get("/api/commands/unknown").status_code == 404
    r = client.post("/api/commands", json={"type": "set_gaze", "target": [1, 0, 0]})
    assert r.status_code == 404  # the idle program declares no gaze_target


def test_led_override_and_speech_reach_the_frames(client, session):
    import time

    from backend.engine.runtime import Sink

    frames = []
    probe = session.engine.add_sink(Sink("probe", consume=frames.append, max_queue=4096))
    client.post("/api/commands", json={"type": "set_led", "dof": "chest_led", "colour": [0, 1, 0]})
    client.post("/api/commands", json={"type": "say", "text": "hello"})
    leds = session.embodiment.dof("chest_led").channels

    def arrived() -> bool:
        return (
            any(e.kind == "say" and e.payload.get("text") == "hello" for f in list(frames) for e in f.events)
            and bool(frames)
            and list(frames[-1].position[leds]) == [0.0, 1.0, 0.0]
        )

    deadline = time.monotonic() + 10.0  # a generous bound for a loaded machine, not a timing goal
    while not arrived() and time.monotonic() < deadline:
        time.sleep(0.01)
    session.engine.remove_sink(probe)
    assert arrived()


def test_status_and_previz_without_viser(client):
    status = client.get("/api/status").json()
    assert status["running"] and status["level"] == 3 and status["tick_cost"]["samples"] > 0
    assert client.get("/api/previz").json()["url"] is None
    assert client.put("/api/previz/ghost", json={"visible": False}).status_code == 404


def test_body_size_limit(client):
    r = client.put("/api/program", content=b"x" * 1_100_000, headers={"content-type": "application/json"})
    assert r.status_code == 413


def test_token_required_for_mutations_and_websockets(session):
    with TestClient(create_app(session, token="s3cret", frontend_dir=None)) as c:
        assert c.get("/api/robot").status_code == 200  # reading is open
        r = c.post("/api/commands", json={"type": "reset"})
        assert r.status_code == 401 and r.json()["detail"]["code"] == "unauthorized"
        assert (
            c.post(
                "/api/commands", json={"type": "reset"}, headers={"Authorization": "Bearer s3cret"}
            ).status_code
            == 200
        )
        assert c.put("/api/inputs/arousal", json={"value": 0.1}).status_code == 401
        with pytest.raises(WebSocketDisconnect), c.websocket_connect("/ws/control") as ws:
            ws.receive_json()
        with c.websocket_connect("/ws/control?token=s3cret") as ws:
            ws.send_json({"type": "reset"})
            assert ws.receive_json()["type"] in ("ack", "event")


def test_ws_control_acks_errors_and_events(client):
    with client.websocket_connect("/ws/control") as ws:
        ws.send_json({"id": "c1", "type": "set_face", "expression": "grin"})
        msgs = [ws.receive_json() for _ in range(2)]
        assert {"ack", "event"} == {m["type"] for m in msgs}
        ack = next(m for m in msgs if m["type"] == "ack")
        assert ack["id"] == "c1" and ack["status"] == "completed"
        ws.send_json({"id": "c2", "type": "set_face", "expression": "confused"})
        err = ws.receive_json()
        assert err["type"] == "error" and err["id"] == "c2" and "no option 'confused'" in err["message"]
        ws.send_text("{bad")
        assert ws.receive_json()["code"] == "malformed_json"


def test_ws_telemetry_signals_frames_and_layers(client):
    with client.websocket_connect("/ws/telemetry") as ws:
        ws.send_json(
            {
                "type": "subscribe",
                "signals": [{"node": "breathe", "port": "out"}, {"node": "in_arousal", "port": "value"}],
                "rate": 60,
            }
        )
        msg = ws.receive_json()
        while msg["type"] != "subscribed":
            msg = ws.receive_json()
        msg = ws.receive_json()
        while "signals" not in msg:
            msg = ws.receive_json()
        assert msg["signals"]["in_arousal.value"] == 0.0
        assert msg["signals"]["breathe.out"]["mask"] >= 9
        assert "head_yaw" in msg["frame"]["position"] and "head_yaw" in msg["frame"]["stage1"]
        assert all(c in (1, 2, 3) for c in msg["frame"]["classes"].values())  # only violations are listed
        assert [layer["name"] for layer in msg["layers"]["mix"]] == ["base", "posture", "idle"]
        ws.send_json({"type": "subscribe", "rate": 1000})
        err = ws.receive_json()
        while err["type"] != "error":
            err = ws.receive_json()
        assert err["field"] == "rate"


def test_ws_frames_json_and_msgpack(client):
    import msgpack

    with client.websocket_connect("/ws/frames?format=json") as ws:
        a, b = ws.receive_json(), ws.receive_json()
        assert b["seq"] > a["seq"] and "eye_leds" in a["dofs"] and "velocity" in a["dofs"]["head_yaw"]
    with client.websocket_connect("/ws/frames?format=msgpack&decimate=2") as ws:
        a, b = msgpack.unpackb(ws.receive_bytes()), msgpack.unpackb(ws.receive_bytes())
        assert b["seq"] - a["seq"] == 2


def test_long_action_reports_started_then_completed(client):

    with client.websocket_connect("/ws/control") as ws:
        r = client.post("/api/commands", json={"type": "go_posture", "posture": "curious", "duration": 0.3})
        assert r.status_code == 200 and r.json()["status"] == "started"
        cid = r.json()["id"]
        events = []
        while "completed" not in events:
            msg = ws.receive_json()
            assert "command_id" not in msg  # one event shape: the command's id is `id`
            if msg.get("id") == cid:
                events.append(msg["event"])
        assert events == ["started", "completed"]  # started once, not once per reporter
    assert client.get(f"/api/commands/{cid}").json()["status"] == "completed"
    r = client.post("/api/commands", json={"type": "go_posture", "posture": "sad", "duration": 5})
    cid = r.json()["id"]
    assert client.delete(f"/api/commands/{cid}").json()["status"] == "cancelled"


def test_unexpected_errors_are_json_500s_without_a_traceback(session, tmp_path, monkeypatch):
    def boom(*_, **__):
        raise RuntimeError("secret internals /etc/passwd")

    monkeypatch.setattr(session, "validate", boom)
    with TestClient(create_app(session, frontend_dir=None), raise_server_exceptions=False) as c:
        r = c.post("/api/program/validate", json={"nodes": []})
        assert r.status_code == 500
        assert r.json() == {
            "detail": {"code": "internal_error", "message": "the server could not handle this request"}
        }
        assert "secret" not in r.text and "Traceback" not in r.text
        assert c.get("/api/robot").status_code == 200  # and the server goes on


def test_errors_keep_the_contract_shape(client):
    r = client.get("/api/no-such-route")
    assert r.status_code == 404 and r.json()["detail"]["code"] == "not_found"
    r = client.put("/api/inputs/arousal", json={"volume": 1})
    assert r.status_code == 422 and r.json()["detail"] == {
        "code": "invalid_body",
        "message": "value: Field required",
        "field": "value",
    }
    r = client.post(
        "/api/commands", content=rb'{"type": "\ud800"}', headers={"content-type": "application/json"}
    )
    assert (
        r.status_code == 400
        and r.json()["detail"]["code"] == "invalid_unicode"
        and r.json()["detail"]["field"] == "type"
    )
    r = client.post(
        "/api/commands",
        content=b'{"type": "set_led", "colour": [1e999, 0, 0]}',
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 400 and r.json()["detail"] == {
        "code": "non_finite",
        "message": "colour[0]: NaN and infinity are not allowed",
        "field": "colour[0]",
    }


def test_previz_info_without_viser(client):
    assert client.get("/api/previz").json() == {
        "url": None,
        "direct": None,
        "token_required": False,
        "ghost": None,
    }
    assert client.get("/previz/").status_code == 404


def test_set_inputs_is_all_or_nothing(client, session):
    client.put("/api/inputs/arousal", json={"value": 0.25})
    r = client.post("/api/commands", json={"type": "set_inputs", "values": {"arousal": 0.5, "nope": 1}})
    assert r.status_code == 422 and r.json()["detail"]["field"] == "nope"
    assert (
        client.get("/api/inputs").json()["values"]["arousal"] == 0.25
    )  # the valid one was not applied either
