"""The editor's generated types come from the backend's models: this fails when the two drift.

Regenerate with `cd frontend && npm run gen:types` (it runs `nutty schema` and json-schema-to-typescript).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from backend.commands.schema import schemas

GENERATED = Path(__file__).resolve().parents[1] / "frontend" / "node_editor" / "generated"


@pytest.mark.parametrize("name", ["program.schema.json", "commands.schema.json", "blocks.json"])
def test_committed_schema_matches_the_backend(name):
    committed = json.loads((GENERATED / name).read_text())
    current = json.loads(json.dumps(schemas()[name], sort_keys=True))
    assert committed == current, f"frontend/node_editor/generated/{name} is stale: run `npm run gen:types` in frontend/"


def test_generated_typescript_names_every_command():
    ts = (GENERATED / "commands.ts").read_text()
    for kind in ("play_clip", "go_posture", "set_gaze", "set_layer", "say", "set_led", "set_emotion", "stop_all"):
        assert f'"{kind}"' in ts
    assert "export interface Program" in (GENERATED / "program.ts").read_text()
