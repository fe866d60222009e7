"""Every route declares what it answers, with the models the editor's TypeScript types come from.

- Each HTTP route of the API has a response model, and /openapi.json (what /docs shows) a 2xx response
  schema for it: a named model, not an untyped object.
- Each route's model is one of backend.api_types.API_MODELS (or a list of one), the models `nutty
  schema` exports and `npm run gen:types` compiles (tests/test_editor_types.py keeps the generated files
  current and checks every API model has its TypeScript type).
- Real answers of the routes whose models are not checked elsewhere conform to them strictly.
"""

from __future__ import annotations

import json
import shutil
import typing
from pathlib import Path

import pytest
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient
from pydantic import BaseModel, TypeAdapter

from backend import api_types as T
from backend.api import ROUTERS, create_app
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json"
PLAIN = (str, list[str])  # answers whose type is the whole story (names, URDF text)


def api_routes() -> list[APIRoute]:
    routes = [r for router in ROUTERS for r in router.routes if isinstance(r, APIRoute)]
    return [r for r in routes if r.include_in_schema]


def operations() -> list[tuple[APIRoute, str]]:
    return [(r, m) for r in api_routes() for m in sorted(r.methods)]


def op_id(item: tuple[APIRoute, str]) -> str:
    return f"{item[1]} {item[0].path}"


@pytest.fixture(scope="module")
def session(desk):
    s = EngineSession.create(desk, rate=100, program=json.loads(PROGRAM.read_text()))
    s.engine.start()
    yield s
    s.engine.close()


@pytest.fixture(scope="module")
def client(session, tmp_path_factory):
    session.library.folder = tmp_path_factory.mktemp("library")  # saves never touch the repository
    for kind in ("programs", "clips"):
        shutil.copytree(PROGRAM.parents[1] / kind, session.library.folder / kind)
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


@pytest.fixture(scope="module")
def openapi(client):
    return client.get("/openapi.json").json()


def test_the_api_has_its_routes():
    assert len(operations()) >= 40


@pytest.mark.parametrize("item", operations(), ids=op_id)
def test_every_route_documents_its_answer(item, openapi):
    route, method = item
    op = openapi["paths"][route.path_format.replace(":path", "")][method.lower()]
    answers = {code: r for code, r in op["responses"].items() if code.startswith("2")}
    assert answers, "no 2xx response"
    for answer in answers.values():
        content = answer.get("content")
        assert content, "a 2xx response without content"
        for media, body in content.items():
            schema = body.get("schema")
            assert schema, f"{media}: no schema"
            if media == "application/json":
                named = schema.get("items", schema) if schema.get("type") == "array" else schema
                assert "$ref" in named or named.get("type") == "string", f"an untyped answer: {schema}"


@pytest.mark.parametrize("item", operations(), ids=op_id)
def test_every_json_route_answers_with_an_api_model(item):
    route, _ = item
    model = route.response_model
    if model is None:  # a binary answer (a GLB): its schema is in `responses`
        assert route.responses
        return
    if model in PLAIN:
        return
    if typing.get_origin(model) is list:
        (model,) = typing.get_args(model)
    assert model in T.API_MODELS, f"{route.path}: {model} is not exported to the editor's types"


def conforms(model, response):
    assert response.status_code == 200, response.text
    if isinstance(model, type) and issubclass(model, BaseModel):
        return model.model_validate_json(response.text, strict=True)
    return TypeAdapter(model).validate_json(response.text, strict=True)


def test_status_and_profile(client):
    status = conforms(T.ServerStatus, client.get("/api/status"))
    assert status.running and status.previz is None and status.clients.control == 0
    assert conforms(T.Profile, client.get("/api/profile")).nodes
    fresh = conforms(T.Profile, client.delete("/api/profile"))  # a new window: the clock keeps ticking
    assert fresh.samples <= fresh.window and [n.node for n in fresh.nodes]


def test_command_log(client):
    ack = conforms(
        T.CommandAccepted,
        client.post(
            "/api/commands", json={"id": "r1", "type": "play_clip", "clip": "nod", "node": "gesture"}
        ),
    )
    entry = conforms(T.CommandEntry, client.get(f"/api/commands/{ack.id}"))
    assert entry.type == "play_clip" and entry.created > 0
    assert conforms(T.CommandCancelled, client.delete(f"/api/commands/{ack.id}")).status == "cancelled"


def test_library_documents(client):
    clip = conforms(T.StoredClip, client.get("/api/clips/nod")).root
    assert clip["name"] == "nod"
    assert conforms(T.StoredProgram, client.get("/api/programs/interactive")).root["nodes"]
    assert conforms(T.Saved, client.put("/api/clips/nod_copy", json=clip)).saved == "nod_copy"
    assert conforms(T.Deleted, client.delete("/api/clips/nod_copy")).deleted == "nod_copy"
    posture = conforms(T.StoredPosture, client.get("/api/postures/curious")).root
    assert posture["builtin"] is True and posture["values"]
    assert conforms(T.JsonSchemaDocument, client.get("/api/schema/commands")).root["oneOf"]


def test_tools(client):
    plain = conforms(T.Tools, client.get("/api/tools")).root
    assert isinstance(plain, T.ToolSet) and plain.tools
    openai = conforms(T.Tools, client.get("/api/tools", params={"format": "openai"})).root
    assert isinstance(openai, list) and isinstance(openai[0], T.OpenAITool)
    anthropic = conforms(T.Tools, client.get("/api/tools", params={"format": "anthropic"})).root
    assert isinstance(anthropic, list) and isinstance(anthropic[0], T.AnthropicTool)
    called = conforms(T.ToolAnswer, client.post("/api/tools/play_clip", json={"clip": "nod"})).root
    assert isinstance(called, T.ToolCalled) and called.command == "play_clip"
    status = conforms(T.ToolAnswer, client.post("/api/tools/get_status", json={"id": called.id})).root
    assert isinstance(status, T.RobotStatusAnswer) and status.command and status.command.id == called.id


def test_trajectory_helper_and_ghost(client):
    tracks = {"rate": 50, "tracks": {"head_pitch": [0.0, 0.5, 1.0, 0.2]}}
    analysis = conforms(T.TrackAnalysis, client.post("/api/analyze", json=tracks))
    assert not analysis.ok and analysis.ranges and "head_pitch" in analysis.dofs
    filtered = conforms(T.FilteredTracks, client.post("/api/filter", json={**tracks, "preset": "A"}))
    assert filtered.preset == "A" and len(filtered.tracks["head_pitch"]) == 4
