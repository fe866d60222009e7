"""/openapi.json (what /docs shows) describes every request body, and each with its real format."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from backend import control
from backend.api import create_app
from backend.commands.serve import builtin_idle
from backend.session import EngineSession

BODY_METHODS = ("post", "put", "patch")


@pytest.fixture(scope="module")
def openapi(desk):
    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    try:
        with TestClient(create_app(session, frontend_dir=None)) as c:
            yield c.get("/openapi.json").json()
    finally:
        session.engine.close()


def _body_schema(openapi: dict, path: str, method: str) -> dict:
    content = openapi["paths"][path][method]["requestBody"]["content"]
    # JSON documents, or a file's bytes (a sound: audio/*, described as binary)
    schema = (content.get("application/json") or next(iter(content.values())))["schema"]
    while "$ref" in schema:
        schema = openapi["components"]["schemas"][schema["$ref"].rsplit("/", 1)[1]]
    return schema


def test_every_route_that_takes_a_body_describes_it(openapi):
    routes = [
        (path, method) for path, ops in openapi["paths"].items() for method in ops if method in BODY_METHODS
    ]
    assert len(routes) >= 10
    for path, method in routes:
        op = openapi["paths"][path][method]
        assert "requestBody" in op, (method, path)
        assert op["requestBody"]["required"] is True, (method, path)
        assert _body_schema(openapi, path, method), (method, path)


def test_documents_are_described_by_their_formats(openapi):
    assert {"nodes", "edges", "inputs"} <= set(_body_schema(openapi, "/api/program", "put")["properties"])
    assert _body_schema(openapi, "/api/program/validate", "post") == _body_schema(
        openapi, "/api/program", "put"
    )
    assert _body_schema(openapi, "/api/programs/{name}", "put") == _body_schema(
        openapi, "/api/program", "put"
    )
    assert "tracks" in _body_schema(openapi, "/api/clips/{name}", "put")["properties"]
    assert "values" in _body_schema(openapi, "/api/postures/{name}", "put")["required"]
    assert _body_schema(openapi, "/api/inputs/{name}", "put")["required"] == ["value"]
    assert _body_schema(openapi, "/api/previz/ghost", "put")["properties"]["visible"]["type"] == "boolean"
    assert "params" in _body_schema(openapi, "/api/blocks/{type_name}/ports", "post")["properties"]
    assert _body_schema(openapi, "/api/program/nodes/{node_id}/params", "patch")["type"] == "object"


def test_the_command_body_is_the_whole_union(openapi):
    schema = _body_schema(openapi, "/api/commands", "post")
    assert set(schema["discriminator"]["mapping"]) == set(
        control.command_json_schema()["discriminator"]["mapping"]
    )
    assert len(schema["oneOf"]) == len(control.REGISTRY.classes())


def test_routes_are_grouped_by_concern(openapi):
    tags = {op["tags"][0] for ops in openapi["paths"].values() for op in ops.values()}
    assert tags == {
        "robot",
        "program",
        "library",
        "commands",
        "tools",
        "status",
        "analysis",
        "clip editor",
        "sounds",
        "behaviours",
    }
