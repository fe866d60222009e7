"""Commands, tool calls and programs are validated strictly: nothing is coerced, a key given twice is
refused, non-finite numbers are refused everywhere, gaze targets are finite and within reach, and the
error says in plain words which field and what range (docs/api-contract.md)."""

from __future__ import annotations

import copy
import json

import pytest
from fastapi.testclient import TestClient
from test_safe_swaps import program

from backend.api import create_app
from backend.session import EngineSession


@pytest.fixture(scope="module")
def client(desk):
    session = EngineSession.create(desk, rate=100, program=program("interactive"))
    with TestClient(create_app(session, frontend_dir=None)) as c:
        c.session = session
        yield c


def post(client, path: str, raw: str):
    return client.post(path, content=raw, headers={"content-type": "application/json"})


@pytest.mark.parametrize(
    "raw, field, words",
    [
        ('{"type": "play_clip", "clip": "nod", "speed": "2"}', "speed", 'speed must be a number, not "2"'),
        ('{"type": "play_clip", "clip": "nod", "speed": true}', "speed", "speed must be a number, not true"),
        (
            '{"type": "set_emotion", "valence": 1e30, "arousal": 0}',
            "valence",
            "valence must be between -1 and 1",
        ),
        ('{"type": "set_emotion", "valence": 0, "arousal": -2}', "arousal", "arousal must be between"),
        ('{"type": "set_gaze", "target": [1e308, 0, 0]}', "target.0", "target.0 must be between -20 and 20"),
        ('{"type": "set_gaze", "target": [1, 0, true]}', "target.2", "target.2 must be a number, not true"),
        ('{"type": "set_gaze", "target": "1,2,3"}', "target", "a JSON array"),
    ],
)
def test_commands_and_tools_refuse_what_they_would_have_coerced(client, raw, field, words):
    for path, body in (("/api/commands", raw), (f"/api/tools/{_tool(raw)}", _arguments(raw))):
        r = post(client, path, body)
        assert r.status_code == 422, (path, r.text)
        detail = r.json()["detail"]
        assert detail["field"] == field and words in detail["message"], (path, detail)


def _tool(raw: str) -> str:
    kind = json.loads(raw)["type"]
    return {"set_gaze": "look_at"}.get(kind, kind)


def _arguments(raw: str) -> str:
    doc = json.loads(raw)
    del doc["type"]
    return json.dumps(doc)


def test_a_key_given_twice_is_refused_naming_it(client):
    r = post(client, "/api/commands", '{"type": "play_clip", "clip": "nod", "clip": "wave"}')
    assert r.status_code == 400 and r.json()["detail"]["code"] == "duplicate_key"
    assert r.json()["detail"]["field"] == "clip" and "twice" in r.json()["detail"]["message"]


@pytest.mark.parametrize(
    "raw",
    [
        '{"type": "set_emotion", "valence": NaN, "arousal": 0}',
        '{"type": "set_gaze", "target": [Infinity, 0, 0]}',
        '{"type": "set_gaze", "target": [1e999, 0, 0]}',
    ],
)
def test_non_finite_numbers_are_refused(client, raw):
    r = post(client, "/api/commands", raw)
    assert r.status_code == 400 and r.json()["detail"]["code"] in ("non_finite", "malformed_json")


def test_a_refused_command_changes_nothing_and_a_good_one_still_works(client):
    before = client.get("/api/inputs").json()
    assert post(client, "/api/commands", '{"type": "set_gaze", "target": [1e308, 0, 0]}').status_code == 422
    assert client.get("/api/inputs").json() == before
    ok = post(client, "/api/commands", '{"type": "set_gaze", "target": [2.0, 0.5, 0.4]}')
    # a long action: taken (within reach), it completes when the gaze has arrived
    assert ok.status_code == 200 and ok.json()["status"] == "started" and ok.json()["result"]["reachable"]


@pytest.mark.parametrize("bad", [True, "0.3"])
def test_program_parameters_are_not_coerced(client, bad):
    doc = copy.deepcopy(program("interactive"))
    node = next(n for n in doc["nodes"] if n["type"] == "breathe")
    node["params"]["amplitude"] = bad
    report = client.post("/api/program/validate", json=doc).json()
    assert not report["valid"]
    (err,) = report["errors"]
    assert err["node"] == node["id"] and err["port"] == "amplitude" and "number" in err["message"]
    r = client.patch(f"/api/program/nodes/{node['id']}/params", json={"amplitude": bad})
    assert r.status_code == 422


def test_nesting_too_deep_for_a_parser_names_the_field(client):
    r = post(client, "/api/commands", '{"type": "set_gaze", "target": ' + "[" * 5000 + "]" * 5000 + "}")
    assert r.status_code == 400
    assert r.json()["detail"]["code"] == "too_deep" and r.json()["detail"]["field"] == "target"
