"""Commands as a registry: the union, the schema and the long actions come from the command classes;
a new command is one class; cancelling a long action stops what it started (and nothing else).

The engine clock is not started here: the test ticks it, so every step is deterministic.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import pytest
from fastapi.testclient import TestClient
from pydantic import Field

from backend import control
from backend.api import create_app
from backend.control import REGISTRY, BlockCommand, CommandContext, GoPosture, Target
from backend.session import EngineSession

INTERACTIVE = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs" / "interactive.json"


@pytest.fixture()
def session(desk):
    s = EngineSession.create(desk, rate=100, program_text=INTERACTIVE.read_text())
    yield s
    s.engine.close()


@pytest.fixture()
def client(session):
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


def ticks(session, n: int = 3) -> None:
    for _ in range(n):
        session.engine.tick()


def output(session, node: str, port: str) -> Any:
    return session.engine.apu.signal_value(node, port)


def test_the_union_schema_and_long_actions_come_from_the_registry():
    types = {cls.model_fields["type"].default for cls in REGISTRY.classes()}
    schema = control.command_json_schema()
    assert set(schema["discriminator"]["mapping"]) == types
    assert len(schema["oneOf"]) == len(types) == 18  # 16 + puppet (Blender's live link) + play_behaviour
    assert {
        "play_clip",
        "go_posture",
        "say",
        "play_sound",
        "set_gaze",
        "play_behaviour",
    } == control.LONG_ACTIONS
    for cls in REGISTRY.classes():
        assert cls.acts_on.blocks or cls.acts_on.role != "block", cls  # every command says what it acts on
        # a long action is carried out by a block, or by the engine itself (the behaviour player)
        assert not cls.long_action or cls.acts_on.blocks or cls.acts_on.role == "engine", cls


@pytest.fixture()
def nod():
    """A long action defined the way a newcomer adds one: one class, registered here directly (its entry
    point would, in an installed package: tests/test_plugins.py)."""

    class Nod(BlockCommand):
        """Nod into the 'curious' posture over `duration` seconds (a command defined by a test)."""

        acts_on = Target(blocks=("posture",), what="posture block")
        long_action = True
        type: Literal["test_nod"] = "test_nod"
        duration: float = Field(5.0, gt=0.0, le=30.0)

        def run(self, ctx: CommandContext) -> Any:
            return self.tell(
                ctx, self.block(ctx.session), "go", {"posture": "curious", "duration": self.duration}
            )

        @classmethod
        def stop_owned(cls, block: Any, command_id: str) -> None:
            GoPosture.stop_owned(block, command_id)

    REGISTRY.add(Nod)
    yield Nod
    REGISTRY.remove("test_nod")  # the other tests see the bundled commands only


def test_a_new_long_action_is_one_class(nod, client, session):
    assert "test_nod" in control.command_json_schema()["discriminator"]["mapping"]
    with pytest.raises(control.CommandError) as err:
        control.parse_command({"type": "test_nod", "duration": 99})
    assert err.value.field == "duration"
    ack = client.post("/api/commands", json={"id": "n1", "type": "test_nod"}).json()
    assert ack == {"id": "n1", "status": "started", "result": {"posture": "curious", "duration": 5.0}}
    ticks(session)
    assert output(session, "posture", "moving") is True
    assert client.delete("/api/commands/n1").json() == {"id": "n1", "status": "cancelled"}
    ticks(session)
    assert output(session, "posture", "moving") is False
    assert client.get("/api/commands/n1").json()["type"] == "test_nod"


def test_a_removed_command_is_gone_from_the_union(nod):
    REGISTRY.remove("test_nod")
    with pytest.raises(control.CommandError) as err:
        control.parse_command({"type": "test_nod"})
    assert err.value.field == "type"
    assert "test_nod" not in control.command_json_schema()["discriminator"]["mapping"]


@pytest.mark.parametrize(
    "command, node, port",
    [
        ({"type": "play_clip", "clip": "nod", "mode": "loop", "layer": "gesture"}, "gesture", "playing"),
        ({"type": "go_posture", "posture": "sad", "duration": 20}, "posture", "moving"),
        ({"type": "say", "text": "one two three four five six seven eight nine ten"}, "voice", "speaking"),
        ({"type": "play_sound", "sound": "chirp"}, "sfx", "playing"),
    ],
)
def test_cancelling_a_long_action_stops_its_block(client, session, command, node, port):
    cid = command["type"]
    assert client.post("/api/commands", json={"id": cid, **command}).json()["status"] == "started"
    ticks(session)
    assert output(session, node, port) is True
    assert client.delete(f"/api/commands/{cid}").json() == {"id": cid, "status": "cancelled"}
    ticks(session, 1)
    assert output(session, node, port) is False


def test_cancelling_a_replaced_action_leaves_the_new_one_alone(client, session):
    client.post("/api/commands", json={"id": "p1", "type": "go_posture", "posture": "sad", "duration": 20})
    ticks(session)
    client.post("/api/commands", json={"id": "p2", "type": "go_posture", "posture": "happy", "duration": 20})
    ticks(session)
    assert client.get("/api/commands/p1").json()["status"] == "cancelled"  # replaced by p2 on the same block
    ack = client.post("/api/commands", json={"id": "k", "type": "cancel", "target": "p1"}).json()
    assert ack == {"id": "k", "status": "completed", "result": {"target": "p1", "status": "cancelled"}}
    ticks(session)
    assert output(session, "posture", "moving") is True
    assert client.get("/api/commands/p2").json()["status"] == "started"


def test_cancel_in_process_says_no_command_log_is_kept(session):
    with pytest.raises(control.CommandError) as err:
        session.execute({"type": "cancel", "target": "t1"})
    assert err.value.code == "unknown_command" and err.value.field == "target"


def test_one_finite_number_check_for_every_entry_point(client):
    """REST, /ws/control and in-process callers refuse NaN/inf alike, naming the same field."""
    body = b'{"type": "set_gaze", "target": [1e999, 0, 0]}'
    r = client.post("/api/commands", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 400 and r.json()["detail"]["code"] == "non_finite"
    assert r.json()["detail"]["field"] == "target[0]"
    with client.websocket_connect("/ws/control") as ws:
        ws.send_text(body.decode())
        err = ws.receive_json()
        assert (err["type"], err["code"], err["field"]) == ("error", "non_finite", "target[0]")
    with pytest.raises(control.CommandError) as exc:
        control.parse_command({"type": "set_gaze", "target": [math.inf, 0, 0]})
    assert (exc.value.code, exc.value.field) == ("non_finite", "target[0]")
    r = client.put(
        "/api/inputs/gaze_target",
        content=b'{"value": [0.5, -1e999, 0.3]}',
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 400 and r.json()["detail"]["field"] == "value[1]"
