"""The generated tools written for each function-calling dialect.

- `plain` (default): `{"format": "nutty-tools/1", "robot", "program", "revision", "tools": [{name,
  description, parameters, command, long_action}], "library": {clips, postures, behaviours, sounds}}`;
- `openai`: the Chat Completions `tools` list, `[{"type": "function", "function": {name, description,
  parameters}}]`;
- `anthropic`: the Messages API `tools` list, `[{name, description, input_schema}]`;
- `gemini`: a Gemini `tools` entry, `[{"functionDeclarations": [{name, description, parameters}]}]`,
  the schemas in Gemini's OpenAPI subset (backend.tools.dialect_schemas.gemini_schema);
- `mcp`: MCP's `tools/list` tools, `[{name, title, description, inputSchema, annotations}]`, the
  annotations (readOnlyHint, destructiveHint, idempotentHint, openWorldHint) from each tool's declaration.

`strict=True` (openai only): OpenAI's strict function calling (`strict: true`, every object closed and
every property required, null for "not given"; backend.tools.dialect_schemas.strict_schema). `api`
(openai only): `chat` (Chat Completions, the default), `responses` (the Responses API's flat
`{type, name, description, parameters, strict}`) or `realtime` (the Realtime API's session tools,
`{type, name, description, parameters}`).

Otherwise the schema is the tools' own JSON Schema (draft 2020-12, `type: object`) in every dialect.
"""

from __future__ import annotations

from typing import Any, Literal

from backend.tools.build import ToolSet
from backend.tools.dialect_schemas import gemini_schema, strict_schema

FORMATS = ("plain", "openai", "anthropic", "gemini", "mcp")
Format = Literal["plain", "openai", "anthropic", "gemini", "mcp"]
OpenAIApi = Literal["chat", "responses", "realtime"]
PLAIN_FORMAT = "nutty-tools/1"


def _openai(toolset: ToolSet, strict: bool, api: str) -> list[dict[str, Any]]:
    out = []
    for t in toolset.tools:
        fn: dict[str, Any] = {
            "name": t.name,
            "description": t.description,
            "parameters": strict_schema(t.parameters) if strict else t.parameters,
        }
        if strict and api != "realtime":  # the Realtime API's tools take no `strict`
            fn["strict"] = True
        out.append({"type": "function", "function": fn} if api == "chat" else {"type": "function", **fn})
    return out


def _mcp(toolset: ToolSet) -> list[dict[str, Any]]:
    return [
        {
            "name": t.name,
            "title": t.name.replace("_", " ").capitalize(),
            "description": t.description,
            "inputSchema": t.parameters,
            "annotations": {
                "title": t.name.replace("_", " ").capitalize(),
                "readOnlyHint": t.command is None,
                "destructiveHint": t.spec.destructive,
                "idempotentHint": t.spec.idempotent,
                # the tools act on this robot alone, a closed world: no web, no other systems
                "openWorldHint": False,
            },
        }
        for t in toolset.tools
    ]


def render(toolset: ToolSet, fmt: str = "plain", *, strict: bool = False, api: str = "chat") -> Any:
    """The tools in dialect `fmt` (one of FORMATS); ValueError for another, or for `strict` / `api`
    with a dialect that has no such variant."""
    if fmt != "openai" and (strict or api != "chat"):
        raise ValueError(f"strict and api apply to format=openai only, not {fmt!r}")
    if api not in ("chat", "responses", "realtime"):
        raise ValueError(f"api must be chat, responses or realtime, got {api!r}")
    if fmt == "openai":
        return _openai(toolset, strict, api)
    if fmt == "gemini":
        return [
            {
                "functionDeclarations": [
                    {"name": t.name, "description": t.description, "parameters": gemini_schema(t.parameters)}
                    for t in toolset.tools
                ]
            }
        ]
    if fmt == "mcp":
        return _mcp(toolset)
    if fmt == "anthropic":
        return [
            {"name": t.name, "description": t.description, "input_schema": t.parameters}
            for t in toolset.tools
        ]
    if fmt == "plain":
        live = toolset.live
        return {
            "format": PLAIN_FORMAT,
            "robot": live.robot,
            "program": live.program,
            "revision": toolset.revision,
            "tools": [t.plain() for t in toolset.tools],
            "library": {
                "clips": [
                    {"name": c.name, "description": c.description, "duration": c.duration} for c in live.clips
                ],
                "postures": [{"name": c.name, "description": c.description} for c in live.postures],
                "behaviours": [
                    {
                        "name": c.name,
                        "description": c.description,
                        "duration": c.duration,
                        "params": live.behaviour_params.get(c.name, {}),
                    }
                    for c in live.behaviours
                ],
                "sounds": [c.name for c in live.sounds],
            },
        }
    raise ValueError(f"format must be one of {list(FORMATS)}, got {fmt!r}")
