"""Ports: the typed connection points of blocks, which output types an input accepts, and the rules by
which a block derives ports from its parameters.

The rules are data (`PortRule`), not code, so that the editor applies exactly the rules the engine
applies: they travel in the block catalog (`port_rules`), next to the compatibility table
(`compatibility_table()`), and the editor evaluates them the same way (`frontend/node_editor/ports.ts`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator


class PortType(StrEnum):
    """Types of ports. `frame` carries a PAF; the others are scalar signals."""

    frame = "frame"
    float = "float"
    int = "int"
    bool = "bool"
    string = "string"
    vec3 = "vec3"
    colour = "colour"
    event = "event"


# Signal types a value may be implicitly converted between when wiring (numeric widening only).
COMPATIBLE_SIGNALS: dict[PortType, set[PortType]] = {
    PortType.float: {PortType.float, PortType.int, PortType.bool},
    PortType.int: {PortType.int, PortType.bool},
    PortType.bool: {PortType.bool},
    PortType.string: {PortType.string},
    PortType.vec3: {PortType.vec3},
    PortType.colour: {PortType.colour},
    PortType.event: {PortType.event, PortType.string},
    PortType.frame: {PortType.frame},
}


def port_accepts(target: PortType, source: PortType) -> bool:
    """Whether an output of type `source` may feed an input of type `target`."""
    return source in COMPATIBLE_SIGNALS[target]


def compatibility_table() -> dict[str, list[str]]:
    """Input type -> the output types it accepts, as JSON (port types in declaration order)."""
    return {t.value: [s.value for s in PortType if port_accepts(t, s)] for t in PortType}


@dataclass(frozen=True)
class Port:
    type: PortType
    doc: str = ""
    required: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type.value, "doc": self.doc, "required": self.required}


_FIELD = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")


def fill(template: str, values: dict[str, Any]) -> str:
    """`template` with every `{field}` replaced by `values[field]` (no other formatting)."""

    def value(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in values:
            raise ValueError(f"port rule template '{template}' names '{name}', which is not a parameter here")
        return str(values[name])

    return _FIELD.sub(value, template)


class PortRule(BaseModel):
    """Ports a block derives from its parameters, e.g. "for each item of `layers`, an input `{name}_weight`
    of type float". Templates (`name`, `doc`, and `type` when it is one) are filled with `{field}`
    values: of each item of the list parameter `each`, or of the parameters themselves without `each`.
    Without `each` the name is a fixed port name, so only the type and doc follow the parameters."""

    model_config = ConfigDict(frozen=True, extra="forbid", json_schema_serialization_defaults_required=True)

    side: Literal["inputs", "outputs"]
    name: str = Field(..., description="port name; a template such as '{name}_weight' when `each` is set")
    type: str = Field(
        ..., description="a port type, or a template naming the parameter holding one ('{type}')"
    )
    doc: str = Field(default="", description="port doc (a template)")
    each: str | None = Field(
        default=None, description="list parameter: one port per item, templates filled from the item"
    )

    @model_validator(mode="after")
    def _consistent(self) -> PortRule:
        if self.each is None and _FIELD.search(self.name):
            raise ValueError(
                f"port rule '{self.name}': a name template needs `each` (a fixed name otherwise)"
            )
        if not _FIELD.search(self.type):
            PortType(self.type)
        return self

    def ports(self, values: dict[str, Any] | None, defaults: dict[str, Any]) -> dict[str, Port]:
        """The ports for JSON parameter values; with the values unknown (None), a list rule gives no
        port and another one takes the parameters' `defaults`."""
        if self.each is None:
            items = [defaults if values is None else values]
        else:
            items = [] if values is None else values.get(self.each) or []
        out: dict[str, Port] = {}
        for item in items:
            kind = fill(self.type, item)
            try:
                port_type = PortType(kind)
            except ValueError:
                raise ValueError(f"port rule for '{self.name}': '{kind}' is not a port type") from None
            out[fill(self.name, item)] = Port(port_type, fill(self.doc, item))
        return out


def derive_ports(
    rules: tuple[PortRule, ...],
    values: dict[str, Any] | None,
    defaults: dict[str, Any],
    inputs: dict[str, Port],
    outputs: dict[str, Port],
) -> tuple[dict[str, Port], dict[str, Port]]:
    """The declared ports followed by the ports every rule derives from `values`, in rule order."""
    sides = {"inputs": dict(inputs), "outputs": dict(outputs)}
    for rule in rules:
        sides[rule.side].update(rule.ports(values, defaults))
    return sides["inputs"], sides["outputs"]
