"""The one event shape of docs/api-contract.md, on a real uvicorn serving the app with the bundled
interactive program (clip player, posture, say and sound blocks).

Every ack and event for a command carries its `id` (no `command_id`); a long action gets exactly one
`started` and one terminal event (`completed` or `cancelled`); an instant command one `completed`;
a `cancel` command is acked under its own id while its target gets `cancelled`.
"""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path
from types import SimpleNamespace

import httpx
import pytest
from server_process import running_app
from websockets.sync.client import connect as ws_connect

from backend.api import create_app
from backend.session import EngineSession

INTERACTIVE = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs" / "interactive.json"


@pytest.fixture(scope="module")
def server(desk):
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE.read_text())
    session.engine.start()
    try:
        with running_app(create_app(session, frontend_dir=None)) as (_, _, port):  # noqa: SIM117 (the client needs the port the app was given)
            with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30.0) as http:
                yield SimpleNamespace(port=port, http=http, session=session)
    finally:
        session.engine.close()


@pytest.fixture()
def control(server):
    with ws_connect(f"ws://127.0.0.1:{server.port}/ws/control") as ws:
        yield Control(ws)


class Control:
    """A /ws/control client that files every message by command id."""

    def __init__(self, ws):
        self.ws = ws
        self.acks: dict[str, dict] = {}
        self.errors: dict[str, dict] = {}
        self.events: dict[str | None, list[dict]] = defaultdict(list)
        self._probe = 0

    def _take(self) -> dict:
        msg = json.loads(self.ws.recv(timeout=30))
        assert "command_id" not in msg, msg
        if msg["type"] == "event":
            assert "id" in msg and isinstance(msg["event"], str), msg
            self.events[msg["id"]].append(msg)
        elif msg["type"] == "ack":
            self.acks[msg["id"]] = msg
        else:
            assert msg["type"] == "error", msg
            self.errors[msg.get("id")] = msg
        return msg

    def send(self, command: dict) -> dict:
        """Send a command; its ack or error."""
        self.ws.send(json.dumps(command))
        cid = command.get("id")
        while True:
            msg = self._take()
            if msg["type"] in ("ack", "error") and msg.get("id") == cid:
                return msg

    def until(self, cid: str, event: str) -> None:
        while event not in self.kinds(cid):
            self._take()

    def settle(self) -> None:
        """Everything the server had to say about earlier commands has arrived: two probes round-trip
        (each waits for a tick boundary, after which earlier block events are already out)."""
        for _ in range(2):
            self._probe += 1
            self.send({"id": f"probe{self._probe}", "type": "set_emotion", "valence": 0.0, "arousal": 0.0})

    def kinds(self, cid: str) -> list[str]:
        return [e["event"] for e in self.events[cid]]


@pytest.mark.parametrize(
    "command",
    [
        {"type": "go_posture", "posture": "curious", "duration": 0.2},
        {"type": "play_clip", "clip": "nod", "layer": "gesture", "speed": 5.0},
        {"type": "say", "text": "hi"},
        {"type": "play_sound", "sound": "chirp"},
    ],
)
def test_a_long_action_is_started_once_then_completed_all_under_its_id(control, command):
    cid = f"long-{command['type']}"
    ack = control.send({"id": cid, **command})
    assert ack["type"] == "ack" and ack["id"] == cid and ack["status"] in ("started", "completed")
    control.until(cid, "completed")
    control.settle()
    assert control.kinds(cid) == ["started", "completed"]
    assert all(e["command"] == command["type"] and e["id"] == cid for e in control.events[cid])


def test_an_instant_command_gets_one_completed_event(control, server):
    ack = control.send({"id": "led1", "type": "set_led", "colour": [0, 1, 0]})
    assert ack == {"type": "ack", "id": "led1", "status": "completed", "result": ack["result"]}
    control.until("led1", "completed")
    control.settle()
    assert control.kinds("led1") == ["completed"]
    assert control.events["led1"][0]["command"] == "set_led"
    assert server.http.get("/api/commands/led1").json()["status"] == "completed"


def test_cancel_is_acked_under_its_own_id_and_the_target_gets_cancelled(control, server):
    assert (
        control.send({"id": "slow", "type": "go_posture", "posture": "sad", "duration": 20})["status"]
        == "started"
    )
    control.until("slow", "started")
    ack = control.send({"id": "k1", "type": "cancel", "target": "slow"})
    assert ack == {
        "type": "ack",
        "id": "k1",
        "status": "completed",
        "result": {"target": "slow", "status": "cancelled"},
    }
    control.until("slow", "cancelled")
    control.until("k1", "completed")
    control.settle()
    assert control.kinds("slow") == ["started", "cancelled"]
    assert control.kinds("k1") == ["completed"]
    assert server.http.get("/api/commands/slow").json()["status"] == "cancelled"
    assert server.http.get("/api/commands/k1").json()["result"] == {"target": "slow", "status": "cancelled"}
    # cancelling what has already ended changes nothing and sends no event for it
    ack = control.send({"id": "k2", "type": "cancel", "target": "slow"})
    assert ack["result"] == {"target": "slow", "status": "cancelled"}
    err = control.send({"id": "k3", "type": "cancel", "target": "no-such-command"})
    assert err["type"] == "error" and err["code"] == "unknown_command" and err["field"] == "target"
    control.settle()
    assert control.kinds("slow") == ["started", "cancelled"]


def test_delete_cancels_once_and_a_new_action_preempts_the_old(control, server):
    r = server.http.post(
        "/api/commands", json={"id": "rest1", "type": "go_posture", "posture": "sad", "duration": 20}
    )
    assert r.json() == {"id": "rest1", "status": "started", "result": r.json()["result"]}
    control.until("rest1", "started")
    assert server.http.delete("/api/commands/rest1").json() == {"id": "rest1", "status": "cancelled"}
    assert server.http.delete("/api/commands/rest1").json() == {"id": "rest1", "status": "cancelled"}
    control.send({"id": "a", "type": "go_posture", "posture": "happy", "duration": 20})
    control.send({"id": "b", "type": "go_posture", "posture": "neutral", "duration": 0.2})
    control.until("b", "completed")
    control.settle()
    assert control.kinds("rest1") == ["started", "cancelled"]
    assert control.kinds("a") == ["started", "cancelled"]  # replaced by b
    assert control.kinds("b") == ["started", "completed"]


def test_ids_of_live_commands_are_unique(control, server):
    control.send({"id": "dup", "type": "go_posture", "posture": "sad", "duration": 20})
    err = control.send({"id": "dup", "type": "set_led", "colour": [1, 0, 0]})
    assert err["type"] == "error" and err["code"] == "duplicate_id" and err["id"] == "dup"
    r = server.http.post("/api/commands", json={"id": "dup", "type": "set_led", "colour": [1, 0, 0]})
    assert r.status_code == 409
    control.send({"id": "stop-dup", "type": "cancel", "target": "dup"})
    assert (
        control.send({"id": "dup", "type": "set_led", "colour": [1, 0, 0]})["type"] == "ack"
    )  # ended: reusable


def test_rest_commands_get_ids_and_their_events_reach_the_socket(control, server):
    r = server.http.post("/api/commands", json={"type": "set_face", "expression": "grin"})
    cid = r.json()["id"]
    assert isinstance(cid, str) and r.json()["status"] == "completed"
    control.until(cid, "completed")
    assert control.events[cid][0] == {"type": "event", "event": "completed", "id": cid, "command": "set_face"}
