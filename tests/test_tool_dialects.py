"""GET /api/tools in every dialect, each checked against its provider's documented rules (written out
here, not taken from the code under test) and, where the provider ships a schema of its own, against
that (Gemini's google-genai types, MCP's SDK types); a strict OpenAI call with null for every optional
argument is carried out as if they were left out; request ids make retries safe."""

from __future__ import annotations

import re
import threading
import time

import mcp_types
import pytest
from fastapi.testclient import TestClient
from google.genai import types as genai
from jsonschema import Draft202012Validator

from backend.api import create_app
from backend.engine.embodiment import load_embodiment, robots_dir
from backend.session import EngineSession
from tests.tool_calls import example_arguments, example_value

INTERACTIVE = robots_dir() / "nutty_desk" / "programs" / "interactive.json"
NAME = re.compile(r"^[a-zA-Z0-9_-]{1,64}$")  # OpenAI's, Anthropic's and Gemini's rule for a function name

# OpenAI, "Structured Outputs: supported schemas" (strict function calling follows it)
OPENAI_STRICT_ALLOWED = {
    "type", "description", "properties", "required", "additionalProperties", "items", "enum", "const",
    "anyOf", "$defs", "$ref", "pattern", "format", "minimum", "maximum", "exclusiveMinimum",
    "exclusiveMaximum", "multipleOf", "minItems", "maxItems",
}  # fmt: skip
OPENAI_MAX_DEPTH, OPENAI_MAX_PROPERTIES, OPENAI_MAX_ENUM_VALUES = 10, 5000, 1000
# Gemini API reference, `Schema` (a select subset of an OpenAPI 3.0 schema object)
GEMINI_FIELDS = {
    "type", "format", "title", "description", "nullable", "enum", "maxItems", "minItems", "properties",
    "required", "minProperties", "maxProperties", "minLength", "maxLength", "pattern", "example", "anyOf",
    "propertyOrdering", "default", "items", "minimum", "maximum",
}  # fmt: skip
GEMINI_TYPES = {"STRING", "NUMBER", "INTEGER", "BOOLEAN", "ARRAY", "OBJECT"}


@pytest.fixture(scope="module")
def client():
    session = EngineSession.create(
        load_embodiment(robots_dir() / "nutty_desk"), rate=100, program_text=INTERACTIVE.read_text()
    )
    session.engine.start()
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c
    session.engine.close()


def _nodes(schema, depth=1):
    """Every schema node with its object-nesting depth."""
    yield schema, depth
    for prop in schema.get("properties", {}).values():
        yield from _nodes(prop, depth + 1)
    if isinstance(schema.get("items"), dict):
        yield from _nodes(schema["items"], depth)
    for option in schema.get("anyOf", []):
        yield from _nodes(option, depth)


def _accepts_null(node) -> bool:
    kinds = node.get("type") if isinstance(node.get("type"), list) else [node.get("type")]
    return ("null" in kinds or {"type": "null"} in node.get("anyOf", [])) and (
        "enum" not in node or None in node["enum"]
    )


def test_openai_strict_follows_the_strict_mode_rules(client):
    plain = {t["name"]: t for t in client.get("/api/tools").json()["tools"]}
    tools = client.get("/api/tools", params={"format": "openai", "strict": "true"}).json()
    assert len(tools) == len(plain) == 15
    enum_values = 0
    for tool in tools:
        assert tool["type"] == "function"
        fn = tool["function"]
        assert fn["strict"] is True and NAME.match(fn["name"]) and fn["description"]
        schema = fn["parameters"]
        assert schema["type"] == "object" and "anyOf" not in schema  # the root is an object
        Draft202012Validator.check_schema(schema)
        optional = set(plain[fn["name"]]["parameters"]["properties"]) - set(
            plain[fn["name"]]["parameters"]["required"]
        )
        count = 0
        for node, depth in _nodes(schema):
            assert set(node) <= OPENAI_STRICT_ALLOWED, (fn["name"], set(node) - OPENAI_STRICT_ALLOWED)
            assert depth <= OPENAI_MAX_DEPTH
            enum_values += len(node.get("enum", []))
            if "properties" in node:
                count += len(node["properties"])
                assert node["additionalProperties"] is False, fn["name"]
                assert node["required"] == list(node["properties"]), fn["name"]
        assert count <= OPENAI_MAX_PROPERTIES
        for name in optional:  # an argument one may leave out takes null instead
            assert _accepts_null(schema["properties"][name]), (fn["name"], name)
        assert "request_id" in optional
    assert enum_values <= OPENAI_MAX_ENUM_VALUES


def test_openai_api_shapes(client):
    chat = client.get("/api/tools", params={"format": "openai"}).json()
    assert all(set(t) == {"type", "function"} and "strict" not in t["function"] for t in chat)
    responses = client.get(
        "/api/tools", params={"format": "openai", "strict": "true", "api": "responses"}
    ).json()
    assert all(set(t) == {"type", "name", "description", "parameters", "strict"} for t in responses)
    realtime = client.get("/api/tools", params={"format": "openai", "api": "realtime"}).json()
    assert all(set(t) == {"type", "name", "description", "parameters"} for t in realtime)
    bad = client.get("/api/tools", params={"format": "anthropic", "strict": "true"})
    assert bad.status_code == 422 and bad.json()["detail"]["field"] == "strict"


def test_anthropic_tools_are_valid_input_schemas(client):
    for tool in client.get("/api/tools", params={"format": "anthropic"}).json():
        assert set(tool) == {"name", "description", "input_schema"} and NAME.match(tool["name"])
        assert tool["input_schema"]["type"] == "object"
        Draft202012Validator.check_schema(tool["input_schema"])


def test_gemini_declarations_follow_its_schema_subset(client):
    entries = client.get("/api/tools", params={"format": "gemini"}).json()
    assert len(entries) == 1
    parsed = genai.Tool.model_validate(entries[0])  # Google's own types: an unknown field is refused
    assert parsed.function_declarations and len(parsed.function_declarations) == 15
    for decl in entries[0]["functionDeclarations"]:
        assert NAME.match(decl["name"]) and decl["parameters"]["type"] == "OBJECT"
        for node, _ in _nodes(decl["parameters"]):
            assert set(node) <= GEMINI_FIELDS, (decl["name"], set(node) - GEMINI_FIELDS)
            assert node.get("type", "STRING") in GEMINI_TYPES
            if "enum" in node:
                assert node["type"] == "STRING" and all(isinstance(v, str) for v in node["enum"])
            if "properties" in node:
                assert node["propertyOrdering"] == list(node["properties"])
                assert set(node.get("required", [])) <= set(node["properties"])


def test_mcp_tools_carry_annotations_chosen_per_tool(client):
    tools = {t["name"]: t for t in client.get("/api/tools", params={"format": "mcp"}).json()}
    for tool in tools.values():
        mcp_types.Tool.model_validate(tool)  # the MCP SDK's own shape
    hints = {name: t["annotations"] for name, t in tools.items()}
    reads = {"get_status", "get_frame"}
    assert all(hints[name]["readOnlyHint"] is True for name in reads)
    assert all(not h["readOnlyHint"] for name, h in hints.items() if name not in reads)
    assert hints["play_clip"]["idempotentHint"] is False and hints["say"]["idempotentHint"] is False
    assert hints["look_at"]["idempotentHint"] is True and hints["set_posture"]["idempotentHint"] is True
    assert hints["cancel"]["destructiveHint"] is True and hints["play_clip"]["destructiveHint"] is False
    assert not any(h["openWorldHint"] for h in hints.values())


def _nulls(strict_schema, plain_schema):
    """A strict call: required arguments given, every optional one null."""
    given = example_arguments(plain_schema)
    return {name: given.get(name) for name in strict_schema["properties"]}


@pytest.mark.parametrize("name", ["play_clip", "set_posture", "say", "stop", "set_inputs", "get_status"])
def test_a_strict_call_with_nulls_is_carried_out(client, name):
    plain = next(t for t in client.get("/api/tools").json()["tools"] if t["name"] == name)["parameters"]
    strict = next(
        t["function"] for t in client.get("/api/tools", params={"format": "openai", "strict": "true"}).json()
        if t["function"]["name"] == name
    )["parameters"]  # fmt: skip
    args = _nulls(strict, plain)
    if name == "set_inputs":  # every input listed, all but one null
        inputs = strict["properties"]["values"]["properties"]
        first = next(iter(inputs))
        args["values"] = {
            k: (example_value(plain["properties"]["values"]["properties"][k]) if k == first else None)
            for k in inputs
        }
    Draft202012Validator(strict).validate(args)  # what a strict model may send
    r = client.post(f"/api/tools/{name}", json=args)
    assert r.status_code == 200, r.text


def test_a_retried_call_with_its_request_id_acts_once(client):
    started = time.time()
    first = client.post(
        "/api/tools/play_clip", json={"clip": "nod", "request_id": "r-1", "if_busy": "replace"}
    )
    assert first.status_code == 200 and first.json()["replayed"] is False
    again = client.post(
        "/api/tools/play_clip", json={"clip": "nod", "request_id": "r-1", "if_busy": "replace", "wait": True}
    )
    body = again.json()
    assert again.status_code == 200, body
    assert body["replayed"] is True and body["id"] == first.json()["id"]
    assert body["status"] == "completed" and body["waited"] is True  # the retry waited for the first's end
    log = client.app.state.hub.commands
    played = [log.get(cid) for cid in list(log._order)]  # every command the server took
    assert sum(1 for c in played if c and c["type"] == "play_clip" and c["created"] >= started) == 1
    other = client.post("/api/tools/play_clip", json={"clip": "shake", "request_id": "r-1"})
    assert other.status_code == 409 and other.json()["detail"]["field"] == "request_id"


def test_concurrent_repeats_wait_for_the_first_answer(client):
    answers = []

    def call():
        answers.append(
            client.post("/api/tools/say", json={"text": "Hi there", "request_id": "r-2", "wait": True}).json()
        )

    threads = [threading.Thread(target=call) for _ in range(3)]
    for t in threads:
        t.start()
        time.sleep(0.02)
    for t in threads:
        t.join(30)
    assert all("replayed" in a for a in answers), answers
    assert len({a["id"] for a in answers}) == 1 and sorted(a["replayed"] for a in answers) == [
        False,
        True,
        True,
    ]
