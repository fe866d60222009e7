"""Commands that AIs and the editor send to a running engine (REST, WebSocket, `nutty run --commands`).

One registry of command classes (`backend.control.base`): each declares its `type`, its fields, what
it acts on (`acts_on`: block types, or a role — exposed inputs, a layer mixer, the engine, another
command), whether it is a long action (acked `started`, then `completed`/`cancelled` from its block)
and how to cancel it, and `run`. The union every entry point validates against, `parse_command`,
the JSON Schema the editor's TypeScript types come from, and `execute` are built from the registry.

Adding a command: one class in the module of its concern (clips, postures, inputs, display,
lifecycle, puppet), a test, then `cd frontend && npm run gen:types`. The REST API, /ws/control, the Python
client (`NuttyClient.command`) and the editor pick it up.
"""

from __future__ import annotations

from backend.control.base import REGISTRY, BaseCommand, BlockCommand, CommandContext, Target

# The concerns, in the order of the union (and of the generated types).
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

Command = command_union()
LONG_ACTIONS = REGISTRY.long_actions()

__all__ = [
    "LONG_ACTIONS",
    "REGISTRY",
    "BaseCommand",
    "BlockCommand",
    "Cancel",
    "Command",
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
