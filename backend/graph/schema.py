"""The Animation Program format (`nutty-program/1`): the single source of truth.

An Animation Program is to the engine what a shader is to a graphics pipeline: a JSON graph of
Animation Blocks. The editor, the API and the CLI all exchange this document; its JSON Schema is
exported for the editor (`nutty schema`) and the TypeScript types are generated from it.

Semantics (nodes, params, edges, exposed inputs) are kept apart from editor data (`ui`), which the
engine ignores but preserves, so graph -> compiled program -> graph is lossless.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

FORMAT = "nutty-program/1"
ID_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-\.]{0,63}$"
SignalType = Literal["float", "int", "bool", "string", "vec3", "colour", "event"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class Endpoint(_Strict):
    """One end of an edge: a node id and one of its port names."""

    node: str = Field(..., min_length=1)
    port: str = Field(..., min_length=1)


class Edge(_Strict):
    """A connection from an output port to an input port. Each input takes at most one edge."""

    from_: Endpoint = Field(..., alias="from")
    to: Endpoint

    def key(self) -> tuple[str, str, str, str]:
        return (self.from_.node, self.from_.port, self.to.node, self.to.port)


class Node(_Strict):
    """A block instance: its id, block type, parameters by name, and editor-only data."""

    id: str = Field(..., pattern=ID_PATTERN, description="unique within the program")
    type: str = Field(..., min_length=1, description="block type name (see GET /api/blocks)")
    params: dict[str, Any] = Field(default_factory=dict, description="parameters by name; omitted = default")
    ui: dict[str, Any] = Field(default_factory=dict, description="editor data (x, y, colour, collapsed, …)")


class ExposedInput(_Strict):
    """A named program parameter an AI or the editor sets at run time (e.g. `arousal`, `gaze_target`)."""

    name: str = Field(..., pattern=ID_PATTERN)
    type: SignalType = "float"
    default: Any = None
    min: float | None = None
    max: float | None = None
    options: list[str] | None = Field(None, description="allowed values of a string input")
    description: str = ""

    @model_validator(mode="after")
    def _check(self) -> "ExposedInput":
        if self.min is not None and self.max is not None and not self.min < self.max:
            raise ValueError(f"input '{self.name}': min {self.min} must be below max {self.max}")
        if self.default is None:
            self.default = default_for(self.type, self.min, self.max, self.options)
        return self

    def coerce(self, value: Any) -> Any:
        """Check and convert a value for this input; raises ValueError naming the input."""
        return coerce_signal(self.name, self.type, value, self.min, self.max, self.options)


def default_for(kind: str, lo: float | None, hi: float | None, options: list[str] | None) -> Any:
    if kind in ("float", "int"):
        base = 0.0 if lo is None else lo
        if lo is not None and hi is not None and lo <= 0.0 <= hi:
            base = 0.0
        return int(base) if kind == "int" else float(base)
    return {"bool": False, "string": (options or [""])[0], "vec3": [1.0, 0.0, 0.3],
            "colour": [1.0, 1.0, 1.0], "event": None}[kind]


def coerce_signal(name: str, kind: str, value: Any, lo: float | None = None, hi: float | None = None,
                  options: list[str] | None = None) -> Any:
    """Validate a signal value of `kind`; numbers must be finite and within [lo, hi]."""

    def finite(x: Any, what: str) -> float:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(float(x)):
            raise ValueError(f"input '{name}': {what} must be a finite number, got {x!r}")
        return float(x)

    if kind in ("float", "int"):
        x = finite(value, "value")
        if lo is not None and x < lo or hi is not None and x > hi:
            raise ValueError(f"input '{name}': {x:g} is outside [{lo}, {hi}]")
        if kind == "int":
            if x != int(x):
                raise ValueError(f"input '{name}': expects an integer, got {value!r}")
            return int(x)
        return x
    if kind == "bool":
        if not isinstance(value, bool):
            raise ValueError(f"input '{name}': expects true or false, got {value!r}")
        return value
    if kind == "string":
        if not isinstance(value, str):
            raise ValueError(f"input '{name}': expects a string, got {value!r}")
        if options and value not in options:
            raise ValueError(f"input '{name}': '{value}' is not one of {options}")
        return value
    if kind in ("vec3", "colour"):
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise ValueError(f"input '{name}': expects a list of 3 numbers, got {value!r}")
        vec = [finite(v, "each component") for v in value]
        if kind == "colour" and not all(0.0 <= v <= 1.0 for v in vec):
            raise ValueError(f"input '{name}': colour components must be within [0, 1], got {vec}")
        return vec
    if kind == "event":
        return value
    raise ValueError(f"input '{name}': unknown type '{kind}'")


class Program(_Strict):
    """An Animation Program document."""

    format: str = Field(FORMAT, description=f"format and version; this engine reads '{FORMAT}'")
    name: str = Field("untitled", min_length=1, max_length=120)
    description: str = ""
    robot: str | None = Field(None, description="the robot it was written for (informative)")
    rate: float | None = Field(None, ge=30, le=1000, description="preferred tick rate (Hz)")
    max_level: int = Field(3, ge=0, le=3, description="highest APU level the program may use")
    inputs: list[ExposedInput] = Field(default_factory=list, description="exposed inputs")
    nodes: list[Node] = Field(default_factory=list)
    edges: list[Edge] = Field(default_factory=list)
    ui: dict[str, Any] = Field(default_factory=dict, description="editor view data (viewport, …)")

    @field_validator("format")
    @classmethod
    def _format(cls, v: str) -> str:
        if v != FORMAT:
            raise ValueError(f"unsupported format '{v}'; this engine reads '{FORMAT}'")
        return v

    def node(self, node_id: str) -> Node | None:
        for n in self.nodes:
            if n.id == node_id:
                return n
        return None

    def input(self, name: str) -> ExposedInput | None:
        for i in self.inputs:
            if i.name == name:
                return i
        return None

    def to_json_dict(self) -> dict[str, Any]:
        """The document as plain JSON data (edges use the key `from`)."""
        return self.model_dump(mode="json", by_alias=True, exclude_none=True)


def program_json_schema() -> dict[str, Any]:
    """JSON Schema of the program document (exported for the editor and the docs)."""
    schema = Program.model_json_schema(by_alias=True)
    schema["$id"] = "https://nutty.dev/schema/nutty-program-1.json"
    schema["title"] = "Nutty Animation Program"
    return schema
