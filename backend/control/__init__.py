"""Commands that AIs and the editor send to a running engine (REST, WebSocket, `nutty run --commands`).

One registry of command classes (`backend.control.base`): each declares its `type`, its fields, what
it acts on (`acts_on`: block types, or a role — exposed inputs, a layer mixer, the engine, another
command), whether it is a long action (acked `started`, then `completed`/`cancelled` from its block)
and how to cancel it, `run`, and whether it is an AI tool (`ai_tool`, backend.control.ai). The union
every entry point validates against, `parse_command`, the JSON Schema the editor's TypeScript types come
from, `execute` and the AI tools (backend.tools) are built from the registry.

Adding a command: one class in the module of its concern (clips, postures, inputs, display,
lifecycle, puppet), its entry point in pyproject.toml, named after its `type`:

    [project.entry-points."nutty.commands"]
    fall_asleep = "backend.control.sleep:FallAsleep"

then `pip install -e .`, a test, and `cd frontend && npm run gen:types`. The REST API, /ws/control, the
Python client (`NuttyClient.command`), the editor and, with an `ai_tool`, /api/tools and `nutty mcp`
pick it up. Another package adds commands the same way, in its own pyproject.toml (backend.plugins).
"""

from __future__ import annotations

from typing import Any

from backend.control.ai import AiTool, Choice, ToolArgumentError
from backend.control.base import REGISTRY, BaseCommand, BlockCommand, CommandContext, Target

# The bundled commands, importable by name; the registry has them from their entry points.
from backend.control.clips import PlayClip, SeekClip, StopClip
from backend.control.dispatch import (
    cancel_command,
    command_json_schema,
    command_union,
    execute,
    is_long_action,
    parse_command,
)
from backend.control.display import PlaySound, Say, SetFace, SetLed
from backend.control.errors import CommandError
from backend.control.inputs import SetEmotion, SetInput, SetInputs, SetLayer
from backend.control.lifecycle import Cancel, Reset, StopAll
from backend.control.postures import GoPosture, SetGaze, Vec3
from backend.control.puppet import Puppet
from backend.control.targets import blocks_of, find_block

REGISTRY.reload()


def __getattr__(name: str) -> Any:
    # `Command` (the union) and `LONG_ACTIONS` are read from the registry when asked, so they follow a
    # reload (a plugin installed, a test's command).
    if name == "Command":
        return command_union()
    if name == "LONG_ACTIONS":
        return REGISTRY.long_actions()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "REGISTRY",
    "AiTool",
    "BaseCommand",
    "BlockCommand",
    "Cancel",
    "Choice",
    "CommandContext",
    "CommandError",
    "GoPosture",
    "PlayClip",
    "PlaySound",
    "Puppet",
    "Reset",
    "Say",
    "SeekClip",
    "SetEmotion",
    "SetFace",
    "SetGaze",
    "SetInput",
    "SetInputs",
    "SetLayer",
    "SetLed",
    "StopAll",
    "StopClip",
    "Target",
    "ToolArgumentError",
    "Vec3",
    "blocks_of",
    "cancel_command",
    "command_json_schema",
    "command_union",
    "execute",
    "find_block",
    "is_long_action",
    "parse_command",
]
