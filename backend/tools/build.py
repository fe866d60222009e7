"""Tool definitions for the running robot: the declared tools (the commands' `ai_tool` declarations,
gathered by backend.tools.table) whose command the running program can carry out, each with a JSON
Schema of its arguments generated from the command model and filled with the live robot's, program's
and library's values (backend.tools.live).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

from backend.control.base import BlockCommand
from backend.control.session_view import CommandSession
from backend.tools.idempotency import REQUEST_ID_SCHEMA
from backend.tools.live import Live, read_live
from backend.tools.schema import model_arguments, with_choices
from backend.tools.table import ToolSpec, WaitOptions, tool_specs

WAITING = (
    "The answer comes at once with the action's `id` and status (`started`, or `queued`); pass "
    "`wait: true` to answer when it has ended (`completed` or `cancelled`), or poll it with get_status "
    "and stop it early with cancel."
)


@dataclass(frozen=True)
class Tool:
    """One generated tool: name, description, JSON Schema of its arguments, the command type it sends
    (None for get_status), whether that is a long action, and its declaration."""

    name: str
    description: str
    parameters: dict[str, Any]
    command: str | None
    long_action: bool
    spec: ToolSpec

    def plain(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "parameters": self.parameters,
            "command": self.command,
            "long_action": self.long_action,
        }


@dataclass(frozen=True)
class ToolSet:
    """The tools of the running robot and program, with the snapshot they came from and a revision
    (a digest of the definitions: it changes exactly when a tool, an argument or an enum does)."""

    tools: tuple[Tool, ...]
    live: Live

    def get(self, name: str) -> Tool | None:
        return next((t for t in self.tools if t.name == name), None)

    @property
    def revision(self) -> str:
        text = json.dumps([t.plain() for t in self.tools], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def build_tools(session: CommandSession) -> ToolSet:
    """The tools `session` (an EngineSession) offers now."""
    live = read_live(session)
    return ToolSet(tuple(_tool(spec, live) for spec in tool_specs() if spec.available(live)), live)


def _tool(spec: ToolSpec, live: Live) -> Tool:
    command = spec.command
    long_action = bool(command is not None and command.long_action)
    schema = model_arguments(spec.model, hide=spec.hide + _routing_hidden(spec, live))
    props = schema["properties"]
    for name, (choices, what) in spec.choices.items():
        values = choices(live)
        if name in props and values:  # no values known (e.g. a sound player that plays anything): free text
            props[name] = with_choices(props[name], values, what)
    if "layer" in props and issubclass(spec.model, BlockCommand):
        held = {name for t in spec.model.acts_on.blocks for name in live.block_layers.get(t, [])}
        layers = [c for c in live.layers if c.name in held]
        if layers:
            props["layer"] = with_choices(props["layer"], layers, "the layers it can act on")
    if spec.shape is not None:
        spec.shape(live, schema)
    if long_action:
        wait = model_arguments(WaitOptions)
        props.update(wait["properties"])
    props["request_id"] = dict(REQUEST_ID_SCHEMA)
    parts = [spec.summary, spec.notes(live) if spec.notes else "", WAITING if long_action else ""]
    description = " ".join(p for p in parts if p)
    command_type = command.model_fields["type"].default if command is not None else None
    return Tool(spec.name, description, schema, command_type, long_action, spec)


def _routing_hidden(spec: ToolSpec, live: Live) -> tuple[str, ...]:
    """Routing fields a model need not choose: a block command's `node` always (its `layer` says where),
    its `layer` when the program has one target block, a layer mixer's id when it has one mixer."""
    model = spec.model
    hidden: list[str] = []
    if isinstance(model, type) and issubclass(model, BlockCommand):
        hidden.append("node")
        targets = sum(len(live.blocks.get(t, [])) for t in model.acts_on.blocks)
        if targets <= 1 and not spec.layer_choice:
            hidden.append("layer")
    if "mixer" in getattr(model, "model_fields", {}) and len(live.mixers) <= 1:
        hidden.append("mixer")
    return tuple(hidden)
