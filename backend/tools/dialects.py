"""The generated tools written for each function-calling dialect.

- `plain` (default): `{"format": "nutty-tools/1", "robot", "program", "revision", "tools": [{name,
  description, parameters, command, long_action}], "library": {clips, postures}}`;
- `openai`: the Chat Completions `tools` list, `[{"type": "function", "function": {name, description,
  parameters}}]`;
- `anthropic`: the Messages API `tools` list, `[{name, description, input_schema}]`.

`parameters` / `input_schema` is the same JSON Schema (draft 2020-12, `type: object`) in every dialect.
"""

from __future__ import annotations

from typing import Any, Literal

from backend.tools.build import ToolSet

FORMATS = ("plain", "openai", "anthropic")
Format = Literal["plain", "openai", "anthropic"]
PLAIN_FORMAT = "nutty-tools/1"


def render(toolset: ToolSet, fmt: str = "plain") -> Any:
    """The tools in dialect `fmt` (one of FORMATS); ValueError for another."""
    if fmt == "openai":
        return [
            {
                "type": "function",
                "function": {"name": t.name, "description": t.description, "parameters": t.parameters},
            }
            for t in toolset.tools
        ]
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
            },
        }
    raise ValueError(f"format must be one of {list(FORMATS)}, got {fmt!r}")
