"""The editor holds no copy of the backend's rules or types: it uses what is generated from the backend,
and this fails when the two drift.

- Every file `nutty schema` writes (program, command and API schemas, the block catalog with its port
  rules, the wiring rule and categories) is committed in frontend/node_editor/generated/ as the backend
  exports it now, and the TypeScript there is what json-schema-to-typescript makes of it.
- Real responses and WebSocket messages of `create_app` match the API models (backend/api_types.py)
  the editor's types are generated from, strictly, with no key the models do not name.

Regenerate with `cd frontend && npm run gen:types`.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel, TypeAdapter

from backend import api_types as T
from backend.api import create_app
from backend.commands.schema import schemas
from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block
from backend.graph.schema import ExposedInput, Program
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
FRONTEND = ROOT / "frontend"
GENERATED = FRONTEND / "node_editor" / "generated"
PROGRAM = ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json"


# --- the generated files --------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(schemas()))
def test_committed_file_matches_the_backend(name):
    committed = json.loads((GENERATED / name).read_text())
    current = json.loads(json.dumps(schemas()[name], sort_keys=True))
    assert committed == current, (
        f"frontend/node_editor/generated/{name} is stale: run `npm run gen:types` in frontend/"
    )


def test_committed_typescript_matches_the_schemas():
    if shutil.which("node") is None or not (FRONTEND / "node_modules" / "json-schema-to-typescript").exists():
        pytest.skip("node and frontend/node_modules are needed to compile the schemas")
    done = subprocess.run(
        ["node", "scripts/gen-types.mjs", "--check"],
        cwd=FRONTEND,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr


def test_generated_typescript_names_every_command_and_api_type():
    ts = (GENERATED / "commands.ts").read_text()
    for kind in (
        "play_clip",
        "go_posture",
        "set_gaze",
        "set_layer",
        "say",
        "set_led",
        "set_emotion",
        "stop_all",
    ):
        assert f'"{kind}"' in ts
    assert "export interface Program" in (GENERATED / "program.ts").read_text()
    api_ts = (GENERATED / "api.ts").read_text()
    for model in T.API_MODELS:
        assert f"export interface {model.__name__} " in api_ts or f"export type {model.__name__} " in api_ts


def test_catalog_carries_every_port_rule_and_the_editor_rules():
    catalog = {e["type"]: e for e in json.loads((GENERATED / "blocks.json").read_text())}
    for name, cls in BLOCKS.items():
        assert [T.PortRule.model_validate(r) for r in catalog[name]["port_rules"]] == list(cls.port_rules)
    assert [r["name"] for r in catalog["layer_mixer"]["port_rules"]] == ["{name}", "{name}_weight"]
    rules = T.EditorRules.model_validate_json((GENERATED / "rules.json").read_text(), strict=True)
    assert rules.accepts["float"] == ["float", "int", "bool"]
    assert {c.name for c in rules.categories} == {cls.category for cls in BLOCKS.values()}


def test_ports_come_only_from_port_rules():
    """The editor applies port_rules; ports computed any other way would be ports it cannot wire."""
    with pytest.raises(TypeError, match="port_rules"):

        class Sneaky(Block):
            @classmethod
            def ports(cls, params=None):
                return {}, {}


# --- real responses ---------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def session(desk):
    s = EngineSession.create(desk, rate=100, program=json.loads(PROGRAM.read_text()))
    s.engine.start()
    yield s
    s.engine.close()


@pytest.fixture(scope="module")
def client(session, tmp_path_factory):
    session.library.folder = tmp_path_factory.mktemp("library")  # saves never touch the repository
    for kind in ("programs", "clips"):  # ... but the robot's clips stay playable
        shutil.copytree(PROGRAM.parents[1] / kind, session.library.folder / kind)
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


def conforms(model, text: str):
    """`text` parsed strictly by `model` (a pydantic model or a type)."""
    if isinstance(model, type) and issubclass(model, BaseModel):
        return model.model_validate_json(text, strict=True)
    return TypeAdapter(model).validate_json(text, strict=True)


def answer(response, status: int = 200):
    assert response.status_code == status, response.text
    return response.text


def test_block_catalog_and_robot(client):
    blocks = conforms(list[T.BlockEntry], answer(client.get("/api/blocks")))
    assert json.loads(client.get("/api/blocks").text) == json.loads((GENERATED / "blocks.json").read_text())
    assert {b.type for b in blocks} == set(BLOCKS)
    ports = conforms(
        T.BlockPorts,
        answer(client.post("/api/blocks/layer_mixer/ports", json={"params": {"layers": [{"name": "a"}]}})),
    )
    assert list(ports.inputs) == ["a", "a_weight"]
    robot = conforms(T.RobotDescription, answer(client.get("/api/robot")))
    assert robot.dofs and robot.postures


def test_running_program_validation_and_swaps(client):
    running = conforms(T.RunningProgram, answer(client.get("/api/program")))
    program = Program.model_validate(running.program)
    doc = program.to_json_dict()
    assert conforms(T.ValidationReport, answer(client.post("/api/program/validate", json=doc))).valid
    loaded = conforms(T.ProgramLoaded, answer(client.put("/api/program", json=doc)))
    assert loaded.report.valid and loaded.kept
    broken = {
        **doc,
        "edges": [
            *doc["edges"],
            {"from": {"node": "nope", "port": "out"}, "to": {"node": "mix", "port": "base"}},
        ],
    }
    refused = conforms(T.ErrorBody, answer(client.put("/api/program", json=broken), 422))
    assert (
        refused.detail.code == "invalid_program" and refused.detail.report and not refused.detail.report.valid
    )
    applied = conforms(
        T.ParamsApplied, answer(client.patch("/api/program/nodes/nmf/params", json={"sigma": 0.2}))
    )
    assert applied.params["sigma"] == 0.2
    missing = conforms(T.ErrorBody, answer(client.patch("/api/program/nodes/nope/params", json={}), 404))
    assert missing.detail.code == "unknown_node"


def test_inputs_commands_library_and_previz(client):
    inputs = conforms(T.ExposedInputs, answer(client.get("/api/inputs")))
    assert {ExposedInput.model_validate(d).name for d in inputs.declarations} >= {"arousal", "valence"}
    assert conforms(T.InputSet, answer(client.put("/api/inputs/arousal", json={"value": 0.5}))).value == 0.5
    accepted = conforms(
        T.CommandAccepted,
        answer(client.post("/api/commands", json={"type": "set_emotion", "valence": 0.1, "arousal": 0.2})),
    )
    assert accepted.status == "completed"
    assert conforms(list[str], answer(client.get("/api/clips")))
    program = client.get("/api/program").json()["program"]
    assert (
        conforms(T.Saved, answer(client.put("/api/programs/drift_check", json=program))).saved
        == "drift_check"
    )
    assert conforms(T.PrevizInfo, answer(client.get("/api/previz"))).url is None
    assert (
        conforms(
            T.ErrorBody, answer(client.put("/api/previz/ghost", json={"visible": True}), 404)
        ).detail.code
        == "no_previz"
    )


def test_telemetry_messages(client):
    subscribe = T.TelemetrySubscribe(
        type="subscribe",
        signals=[T.SignalRef(node="mix", port="out"), T.SignalRef(node="in_arousal", port="value")],
        frames=True,
        rate=60,
    )
    with client.websocket_connect("/ws/telemetry") as ws:
        ws.send_text(subscribe.model_dump_json())
        seen: dict[str, object] = {}
        while not {"subscribed", "telemetry"} <= seen.keys() or "signals" not in json.loads(
            seen["telemetry"]
        ):
            text = ws.receive_text()
            seen[json.loads(text)["type"]] = text
        ws.send_json({"type": "unsubscribe"})
        while "error" not in seen:
            text = ws.receive_text()
            seen[json.loads(text)["type"]] = text
    messages = {kind: conforms(T.TelemetryMessage, text).root for kind, text in seen.items()}
    telemetry = messages["telemetry"]
    assert {"mix.out", "in_arousal.value"} <= telemetry.signals.keys()
    assert telemetry.frame.position and next(layer.name for layer in telemetry.layers["mix"]) == "base"
    assert messages["error"].code == "invalid_message"


def test_control_messages(client):
    with client.websocket_connect("/ws/control") as ws:
        ws.send_json({"id": "drift1", "type": "play_clip", "clip": "nod", "node": "gesture"})
        kinds: dict[str, str] = {}
        while not {"ack", "event"} <= kinds.keys():
            text = ws.receive_text()
            kinds.setdefault(json.loads(text)["type"], text)
        ws.send_json({"id": "drift2", "type": "play_clip", "clip": "no_such_clip", "node": "gesture"})
        while "error" not in kinds:
            text = ws.receive_text()
            if json.loads(text)["type"] == "error":
                kinds["error"] = text
    messages = {kind: conforms(T.ControlMessage, text).root for kind, text in kinds.items()}
    assert messages["ack"].id == "drift1" and messages["event"].id == "drift1"
    assert messages["event"].command == "play_clip"
    assert messages["error"].id == "drift2"
