"""An engine on Zenoh in this process (EngineLink around a real Hub and clock) and a Fleet talking to it
over loopback: commands validated exactly as REST validates them, events under the command's id,
queries, the refusals, and the shipped access-control examples (docs/fleet/)."""

from __future__ import annotations

import json
import re
import threading
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.client import NuttyError
from backend.fleet import Fleet
from backend.session import EngineSession
from backend.zenoh_link import keys
from backend.zenoh_link.codec import encode_json
from backend.zenoh_link.engine import EngineLink
from backend.zenoh_link.session import ZenohOptions, ZenohSetupError
from tests.fleet_processes import local_config, loopback, poll
from tests.test_command_registry import INTERACTIVE

DOCS = Path(__file__).resolve().parents[1] / "docs" / "fleet"


class Served:
    """An engine with its API app (for REST comparisons) and its Zenoh link."""

    def __init__(self, desk, options: ZenohOptions, robot_id: str = "unit-1"):
        self.session = EngineSession.create(desk, rate=50)
        self.session.load_program(INTERACTIVE.read_text())
        self.app = create_app(self.session)
        self.hub = self.app.state.hub
        self.closing = threading.Event()
        self.session.engine.start()
        self.link = None
        try:
            self.link = EngineLink.open(options, robot_id).start(self.hub, self.closing)
        except BaseException:
            self.session.engine.close()
            raise

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
        self.session.engine.close()


@pytest.fixture
def served(desk, tmp_path):
    endpoint = loopback()
    config = local_config(tmp_path)
    engine = Served(desk, ZenohOptions(listen=[endpoint], config_file=config))
    fleet = None
    try:
        fleet = Fleet(connect=[endpoint], config=config, timeout=5.0)
        yield engine, fleet
    finally:
        if fleet is not None:
            fleet.close()
        engine.close()


def ask_raw(fleet: Fleet, robot: str, payload: bytes) -> dict:
    return fleet.ask(robot, keys.COMMANDS, payload)[robot]


# The same bytes to POST /api/commands and to nutty/<id>/commands: the same status, code and field.
BAD_COMMANDS = [
    b'{"type": "warp_drive"}',
    b'{"type": "set_face"}',
    b'{"type": "set_face", "expression": 7}',
    b'{"type": "set_led", "colour": [1, 0, 0, 1]}',
    b'{"type": "go_posture", "posture": "no_such_posture"}',
    b'{"type": "set_gaze", "target": [1e999, 0, 0]}',
    b'{"type": "set_gaze", "target": [NaN, 0, 0]}',
    b'{"type": "say", "text": "\\ud800"}',
    b'{"type": "say", "text": "hi", "extra": ' + b"[" * 70 + b"]" * 70 + b"}",
    b'{"type": "say", "text": "hi", "n": 123456789012345678901234567890}',
    b'{"type": "say", "text": "hi"',
    b'{"type": "cancel", "target": "nothing-by-that-id"}',
    b"\xff\xfe",
]


def test_a_command_from_zenoh_is_validated_exactly_like_one_from_rest(served):
    engine, fleet = served
    rest = TestClient(engine.app)
    for raw in BAD_COMMANDS:
        r = rest.post("/api/commands", content=raw, headers={"content-type": "application/json"})
        assert r.status_code >= 400, raw
        want = r.json()["detail"]
        got = ask_raw(fleet, "unit-1", raw)
        assert got["type"] == "error", raw
        assert (got["status"], got["code"], got.get("field")) == (
            r.status_code,
            want["code"],
            want.get("field"),
        ), raw
    assert fleet["unit-1"].status()["zenoh"]["errors"] == len(BAD_COMMANDS)


def test_a_good_command_is_acked_logged_and_its_events_follow_under_its_id(served):
    engine, fleet = served
    rest = TestClient(engine.app)
    with fleet.watch("unit-1", presence=False) as watch:
        ack = fleet["unit-1"].command("say", text="hello from zenoh", id="z-say-1")
        assert ack == {"id": "z-say-1", "status": "started", "result": ack["result"]}
        events = []
        poll(
            lambda: (
                events.append(watch.get(timeout=0.2))
                or any(e and e.get("event") == "completed" for e in events)
            )
        )
    events = [e for e in events if e]
    assert [e["event"] for e in events] == ["started", "completed"]
    assert all(e["id"] == "z-say-1" and e["command"] == "say" and e["robot"] == "unit-1" for e in events)
    # The same command log as REST: GET /api/commands/{id} knows it; a second one with its id while it runs is 409.
    assert rest.get("/api/commands/z-say-1").json()["status"] == "completed"
    long = fleet["unit-1"].posture("sleepy", duration=5.0)
    with pytest.raises(NuttyError) as dup:
        fleet["unit-1"].command("go_posture", posture="sleepy", id=long["id"])
    assert dup.value.status == 409 and dup.value.code == "duplicate_id"
    assert fleet["unit-1"].cancel(long["id"]) == {"id": long["id"], "status": "cancelled"}
    assert rest.get(f"/api/commands/{long['id']}").json()["status"] == "cancelled"


def test_a_put_command_is_answered_on_events_and_rest_commands_are_published_too(served):
    engine, fleet = served
    with fleet.watch("unit-1", presence=False) as watch:
        fleet.session.put(
            keys.key("unit-1", keys.COMMANDS),
            encode_json({"type": "set_face", "expression": "grin", "id": "put-1"}),
        )
        fleet.session.put(keys.key("unit-1", keys.COMMANDS), b'{"type": "set_face", "id": "put-2"}')
        TestClient(engine.app).post(
            "/api/commands", json={"type": "set_face", "expression": "smile", "id": "rest-1"}
        )
        seen: list = []
        poll(lambda: seen.append(watch.get(timeout=0.2)) or sum(1 for e in seen if e) >= 4)
    seen = [e for e in seen if e]
    assert {
        "type": "ack",
        "id": "put-1",
        "status": "completed",
        "robot": "unit-1",
        "result": {"dof": "mouth", "expression": "grin"},
    } in seen
    error = next(e for e in seen if e["type"] == "error")
    assert (error["id"], error["code"], error["field"], error["status"]) == (
        "put-2",
        "invalid_command",
        "expression",
        422,
    )
    completed = {e["id"] for e in seen if e.get("event") == "completed"}
    assert completed == {"put-1", "rest-1"}  # a REST command's events reach Zenoh watchers as well


def test_only_the_commands_key_itself_carries_commands(served):
    engine, fleet = served
    before = engine.link.counts["commands"]
    fleet.session.put("nutty/**", encode_json({"type": "set_face", "expression": "frown"}))
    answers = [r.ok for r in fleet.session.get("nutty/**", payload=encode_json({"type": "reset"}), timeout=3)]
    command_answers = [
        json.loads(s.payload.to_string()) for s in answers if s and str(s.key_expr).endswith("/commands")
    ]
    assert command_answers and all(a["code"] == "not_a_command_key" for a in command_answers)
    assert {str(s.key_expr) for s in answers if s} == {
        f"nutty/unit-1/{leaf}" for leaf in ("commands", "status", "robot", "program")
    }  # reads do answer
    time.sleep(0.3)
    assert engine.link.counts["commands"] == before


def test_queries_answer_as_the_rest_api_does(served):
    engine, fleet = served
    rest = TestClient(engine.app)
    robot = fleet["unit-1"]
    assert robot.robot() == rest.get("/api/robot").json()
    assert robot.program() == rest.get("/api/program").json()
    status = robot.status()
    assert status["robot_id"] == "unit-1" and status["rate"] == 50.0 and status["running"]
    assert list(fleet.status("unit-*")) == ["unit-1"] and fleet.status("*")["unit-1"]["robot_id"] == "unit-1"
    with pytest.raises(NuttyError) as refused:
        robot.tune("breathe", amplitude=0.1)
    assert refused.value.status == 405 and refused.value.code == "not_on_zenoh"
    with pytest.raises(NuttyError) as no_tools:  # the AI tools are HTTP's (docs/ai.md): said, not a crash
        robot.call_tool("play_clip", clip="nod", wait=True)
    assert no_tools.value.code == "not_on_zenoh"
    with pytest.raises(NuttyError) as missing:
        fleet["unit-2"].status()
    assert missing.value.status == 404 and missing.value.code == "not_found"


def test_frames_are_the_ws_frames_content_with_an_emission_stamp(served, desk):
    _engine, fleet = served
    got: list = []
    began = time.time()
    sub = fleet.frames("unit-1", lambda rid, doc, sent: got.append((rid, doc, sent, time.time())))
    try:
        poll(lambda: len(got) >= 20)
    finally:
        sub.undeclare()
    rid, doc, sent, arrived = got[-1]
    assert rid == "unit-1" and set(doc) == {"embodiment", "t", "dt", "seq", "dofs", "events", "joints"}
    assert set(doc["dofs"]) == {d.name for d in desk.dofs if d.type.value != "event"}
    assert began - 1.0 <= sent <= arrived  # a Unix time from the tick that made the frame (same clock here)
    seqs = [d["seq"] for _, d, _, _ in got]
    assert seqs == sorted(seqs)


def test_commands_are_refused_while_the_server_shuts_down(served):
    engine, fleet = served
    engine.closing.set()
    with pytest.raises(NuttyError) as refused:
        fleet["unit-1"].say("too late")
    assert refused.value.status == 503 and refused.value.code == "shutting_down"
    assert fleet["unit-1"].status()["robot_id"] == "unit-1"  # reading still works


def test_a_taken_robot_id_is_refused_and_the_token_goes_with_the_engine(served, desk, tmp_path):
    engine, fleet = served
    endpoint = engine.link.options.listen[0]
    with pytest.raises(ZenohSetupError, match="robot id 'unit-1' is taken"):
        EngineLink.open(ZenohOptions(connect=[endpoint], config_file=local_config(tmp_path)), "unit-1")
    assert fleet.robots() == ["unit-1"]
    with fleet.watch("*") as watch:
        engine.link.close()
        poll(lambda: fleet.robots() == [])
        seen = [e for e in iter(lambda: watch.get(timeout=0.5), None)]
    assert {"type": "robot", "event": "vanished", "robot": "unit-1"} in seen


# --------------------------------------------------------------------------------------------------
# The shipped access-control examples
# --------------------------------------------------------------------------------------------------


def shipped(name: str, tmp_path: Path) -> str:
    """docs/fleet/<name> with its users file path made absolute (the examples give it from the repo root)."""
    text = (DOCS / name).read_text().replace('"docs/fleet/users.txt"', json.dumps(str(DOCS / "users.txt")))
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("topology", ["engine", "router"])
def test_the_access_control_examples_let_operators_command_and_viewers_only_watch(desk, tmp_path, topology):
    endpoint = loopback()
    router = None
    opened: list = []
    try:
        if topology == "router":
            router = Fleet(listen=[endpoint], config=shipped("router.json5", tmp_path))
            engine = Served(
                desk, ZenohOptions(connect=[endpoint], config_file=shipped("member.json5", tmp_path))
            )
        else:
            engine = Served(
                desk, ZenohOptions(listen=[endpoint], config_file=shipped("engine.json5", tmp_path))
            )
        opened.append(engine)
        operator = Fleet(connect=[endpoint], config=shipped("operator.json5", tmp_path), timeout=3.0)
        opened.append(operator)
        viewer = Fleet(connect=[endpoint], config=shipped("viewer.json5", tmp_path), timeout=3.0)
        opened.append(viewer)

        poll(lambda: operator.robots() == ["unit-1"] and viewer.robots() == ["unit-1"])
        assert viewer["unit-1"].status()["robot_id"] == "unit-1"
        forged: list = []
        sub = operator.frames(
            "unit-1", lambda rid, doc, sent: forged.append(doc) if doc.get("embodiment") == "forged" else None
        )
        opened.append(sub)

        # A viewer's command gets no answer (Zenoh drops it), runs nothing, and cannot be smuggled in on
        # a wider key either; a forged frame reaches nobody.
        with pytest.raises(NuttyError) as refused:
            viewer["unit-1"].face("frown")
        assert refused.value.code == "no_reply"
        viewer.session.put(
            keys.key("unit-1", keys.COMMANDS), encode_json({"type": "set_face", "expression": "frown"})
        )
        viewer.session.put("nutty/**", encode_json({"type": "set_face", "expression": "frown"}))
        viewer.session.put(keys.key("unit-1", keys.FRAMES), b"\x82\xaaembodiment\xa6forged\xa4dofs\x80")
        time.sleep(0.5)
        assert engine.link.counts["commands"] == 0 and forged == []

        # An operator commands.
        assert operator["unit-1"].face("grin")["status"] == "completed"
        assert engine.link.counts["commands"] == 1
    finally:
        for thing in reversed(opened):
            (thing.undeclare if hasattr(thing, "undeclare") else thing.close)()
        if router is not None:
            router.close()


@pytest.mark.parametrize("credentials", [None, ("viewer", "wrong password")])
def test_the_access_control_example_turns_away_unknown_users(desk, tmp_path, credentials):
    endpoint = loopback()
    engine = Served(desk, ZenohOptions(listen=[endpoint], config_file=shipped("engine.json5", tmp_path)))
    try:
        text = (DOCS / "viewer.json5").read_text()
        text = (
            re.sub(r"transport: .*\n", "", text)
            if credentials is None
            else text.replace("change-me-viewer", credentials[1])
        )
        path = tmp_path / "stranger.json5"
        path.write_text(text)
        with pytest.raises(ZenohSetupError, match="cannot join Zenoh"):
            Fleet(connect=[endpoint], config=str(path)).close()
    finally:
        engine.close()


def test_status_is_published_and_liveliness_is_seen_by_a_watch(served):
    _engine, fleet = served
    with fleet.watch("unit-*", status=True) as watch:
        seen: list = []
        poll(
            lambda: (
                seen.append(watch.get(timeout=0.5))
                or sum(1 for e in seen if e and e["type"] == "status") >= 2
            )
        )
    statuses = [e for e in seen if e and e["type"] == "status"]
    assert all(s["robot"] == s["robot_id"] == "unit-1" for s in statuses)
    assert statuses[1]["ticks"] > statuses[0]["ticks"]
    assert next(e for e in seen if e) == {"type": "robot", "event": "appeared", "robot": "unit-1"}


def test_the_bridge_follows_only_the_running_engines_frames_on_its_own_key(served, desk):
    """Frames are taken only from nutty/<id>/frames itself and only with the session id of the engine whose
    session liveliness token is alive: a put on a wider key, a frame without a session and a forged
    session are refused (counted as foreign), the engine's own frames are followed."""
    from backend.zenoh_link.codec import encode_frame, stamp
    from backend.zenoh_link.follow import follow_frames

    engine, fleet = served
    got, refused = [], []
    follower = follow_frames(
        fleet.session,
        "unit-1",
        lambda doc, sent, sid: got.append((doc["seq"], sid)),
        lambda why, kind="rejected": refused.append(kind),
    )
    try:
        poll(lambda: len(got) >= 5, 10, "the engine's frames")
        sid = engine.link.session_id.hex()
        assert all(s == sid for _, s in got) and follower.live == {sid}
        forged = encode_frame(engine.session.engine.tick(), desk)
        refused.clear()
        fleet.session.put("nutty/**", forged, attachment=stamp(time.time(), engine.link.session_id))
        fleet.session.put("nutty/unit-1/frames", forged, attachment=stamp(time.time()))
        fleet.session.put("nutty/unit-1/frames", forged, attachment=stamp(time.time(), b"\x01" * 16))
        poll(lambda: refused.count("foreign") >= 3, 10, "three forged frames refused")
    finally:
        follower.undeclare()
