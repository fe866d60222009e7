"""How a command is offered to an AI as a tool: the `ai_tool` declaration a command class carries.

A command class with `ai_tool = AiTool(...)` is a tool of `GET /api/tools`, `POST /api/tools/{name}`
and `nutty mcp` (backend.tools builds them from the command registry); one with `ai_tool = None`
(the default) is not offered. The tool's argument schema is generated from the command's fields (or
`fields`), so the declaration says only what a model cannot: the tool's name and one-line summary,
when the running program can carry it out, which arguments take a value that exists now (a clip, a
posture, a layer), and what its description adds.

The callables take `live`, the snapshot of the running robot, program and library the tools are built
from (`backend.tools.live.Live`: clips, postures, inputs, blocks, layers, display DoFs, channels, gaze
range). This module imports nothing of backend.tools: tools depend on commands, not the reverse.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Choice:
    """One value an argument may take, with what a model needs to pick it: a one-line description and,
    for a clip, its duration."""

    name: str
    description: str = ""
    duration: float | None = None  # s (a clip's length)

    def line(self) -> str:
        detail = f" ({self.duration:g} s)" if self.duration is not None else ""
        return f"- {self.name}{detail}: {self.description}" if self.description else f"- {self.name}{detail}"


Choices = Callable[[Any], list[Choice]]


def always(live: Any) -> bool:
    """Offered whatever the robot and program (stop, cancel)."""
    return True


class ToolArgumentError(ValueError):
    """A tool's arguments that cannot become a command (raised by a `route`); `field` names the argument.
    The tool call answers it as an invalid argument."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


@dataclass(frozen=True)
class AiTool:
    """A command offered to an AI.

    name, summary: the tool's name and the first sentence of its description.
    available(live): whether the running program can carry it out now (else it is not offered).
    choices: argument -> (values(live), what they are): the argument becomes an enum of what exists now,
      each value listed with its description (no values: it stays free text).
    hide: fields of the command the tool does not offer.
    fields: the model whose fields are the arguments, when not the command's own (see `route`).
    layer_choice: offer `layer` even when the program has one block the command can act on.
    notes(live): generated text appended to the description.
    shape(live, schema): a last adjustment of the argument schema, in place.
    route(arguments) -> command dict: how the arguments become a command (default: this command with
      those fields); raises ToolArgumentError naming the argument at fault.
    order: position in the tool list (smaller first; equal ones in command-registry order). The bundled
      actions are 10..100, the default (a plugin's tool) is 500, stop, cancel and get_status 900..920.
    idempotent: calling it again with the same arguments has no further effect (a posture, a gaze
      target, a colour); a gesture or a sentence is not: it plays again. MCP's `idempotentHint`.
    destructive: it ends or undoes what is going on (stop, cancel) rather than adding to it. MCP's
      `destructiveHint`.
    """

    name: str
    summary: str
    available: Callable[[Any], bool] = always
    choices: Mapping[str, tuple[Choices, str]] = field(default_factory=dict)
    hide: tuple[str, ...] = ()
    fields: type | None = None
    layer_choice: bool = False
    notes: Callable[[Any], str] | None = None
    shape: Callable[[Any, dict[str, Any]], None] | None = None
    route: Callable[[dict[str, Any]], dict[str, Any]] | None = None
    order: float = 500.0
    idempotent: bool = False
    destructive: bool = False


def input_value_schema(decl: Any) -> dict[str, Any]:
    """The JSON Schema of one exposed input's value, from its declaration (type, range, options)."""
    kind = decl.type
    if kind in ("float", "int"):
        schema: dict[str, Any] = {"type": "number" if kind == "float" else "integer"}
        if decl.min is not None:
            schema["minimum"] = decl.min
        if decl.max is not None:
            schema["maximum"] = decl.max
    elif kind == "bool":
        schema = {"type": "boolean"}
    elif kind == "string":
        schema = {"type": "string", **({"enum": list(decl.options)} if decl.options else {})}
    elif kind in ("vec3", "colour"):
        item: dict[str, Any] = {"type": "number"}
        if kind == "colour":
            item.update(minimum=0.0, maximum=1.0)
        schema = {"type": "array", "items": item, "minItems": 3, "maxItems": 3}
    else:  # an event input takes any JSON value
        schema = {}
    text = decl.description or f"exposed input '{decl.name}'"
    return {**schema, "description": f"{text} (default {decl.default!r})"}
