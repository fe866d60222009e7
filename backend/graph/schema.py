"""The Animation Program format (`nutty-program/1`): the single source of truth.

An Animation Program is to the engine what a shader is to a graphics pipeline: a JSON graph of
Animation Blocks. The editor, the API and the CLI all exchange this document; its JSON Schema is
exported for the editor (`nutty schema`) and the TypeScript types are generated from it.

Semantics (nodes, params, edges, exposed inputs) are kept apart from editor data (`ui`), which the
engine ignores but preserves, so graph -> compiled program -> graph is lossless.
"""

from __future__ import annotations

import math
import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

FORMAT = "nutty-program/1"
ID_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-\.]{0,63}$"
# Node ids may also contain '/': the ids of blocks inside subgraphs (`idle/breathe`), which a program
# written flat can spell out; a subgraph node's own id and its inner ids are plain ID_PATTERN names.
NODE_ID_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-\.]{0,63}(/[A-Za-z_][A-Za-z0-9_\-\.]{0,63}){0,7}$"
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

    id: str = Field(
        ...,
        pattern=NODE_ID_PATTERN,
        description="unique within the program ('/' is for the blocks of subgraphs: `idle/breathe`)",
    )
    type: str = Field(..., min_length=1, description="block type name (see GET /api/blocks)")
    params: dict[str, Any] = Field(default_factory=dict, description="parameters by name; omitted = default")
    ui: dict[str, Any] = Field(default_factory=dict, description="editor data (x, y, colour, collapsed, …)")
    bypass: bool | None = Field(
        default=None,
        description="true: the engine passes the block's first frame input to its first frame output "
        "unchanged (operators, mixers and stage-2 blocks; not the safety limiter); omitted when off",
    )

    @field_validator("bypass")
    @classmethod
    def _bypass_off_is_omitted(cls, v: bool | None) -> bool | None:
        return True if v else None  # `false` and absent are the same document


class ExposedInput(_Strict):
    """A named program parameter an AI or the editor sets at run time (e.g. `arousal`, `gaze_target`)."""

    name: str = Field(..., pattern=ID_PATTERN)
    type: SignalType = "float"
    default: Any = None
    min: float | None = None
    max: float | None = None
    options: list[str] | None = Field(default=None, description="allowed values of a string input")
    description: str = ""

    @model_validator(mode="after")
    def _check(self) -> ExposedInput:
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
    return {
        "bool": False,
        "string": (options or [""])[0],
        "vec3": [1.0, 0.0, 0.3],
        "colour": [1.0, 1.0, 1.0],
        "event": None,
    }[kind]


def coerce_signal(
    name: str,
    kind: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    options: list[str] | None = None,
) -> Any:
    """Validate a signal value of `kind`; numbers must be finite and within [lo, hi]."""

    def finite(x: Any, what: str) -> float:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(float(x)):
            raise ValueError(f"input '{name}': {what} must be a finite number, got {x!r}")
        return float(x)

    if kind in ("float", "int"):
        x = finite(value, "value")
        if (lo is not None and x < lo) or (hi is not None and x > hi):
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


class ExposedPort(_Strict):
    """A port of a subgraph: an inner node's port, shown on the subgraph's node under `name`."""

    name: str = Field(..., pattern=ID_PATTERN, description="the port's name on the subgraph node")
    node: str = Field(..., min_length=1, description="the inner node whose port this is")
    port: str = Field(..., min_length=1, description="the inner node's port")


SUBGRAPH_TYPE = "subgraph"  # the `type` of a node that uses a subgraph (`params.subgraph` names it)
SUBGRAPH_PARAM = "subgraph"


class Subgraph(_Strict):
    """A reusable group of blocks (like a Blender node group): inner nodes and edges, and which inner
    ports the group exposes. A node `{"type": "subgraph", "params": {"subgraph": NAME}}` uses it; its
    inner nodes run as `<that node's id>/<inner id>`."""

    description: str = ""
    nodes: list[Node] = Field(default_factory=list)
    edges: list[Edge] = Field(default_factory=list)
    inputs: list[ExposedPort] = Field(default_factory=list, description="exposed inner input ports")
    outputs: list[ExposedPort] = Field(default_factory=list, description="exposed inner output ports")
    ui: dict[str, Any] = Field(default_factory=dict, description="editor view data of the inside")

    @model_validator(mode="after")
    def _unique_ports(self) -> Subgraph:
        for kind, ports in (("input", self.inputs), ("output", self.outputs)):
            names = [p.name for p in ports]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"exposed {kind} name(s) {dup} used more than once")
        return self


class Program(_Strict):
    """An Animation Program document."""

    format: str = Field(default=FORMAT, description=f"format and version; this engine reads '{FORMAT}'")
    name: str = Field(default="untitled", min_length=1, max_length=120)
    description: str = ""
    robot: str | None = Field(default=None, description="the robot it was written for (informative)")
    rate: float | None = Field(default=None, ge=30, le=1000, description="preferred tick rate (Hz)")
    max_level: int = Field(default=3, ge=0, le=3, description="highest APU level the program may use")
    inputs: list[ExposedInput] = Field(default_factory=list, description="exposed inputs")
    nodes: list[Node] = Field(default_factory=list)
    edges: list[Edge] = Field(default_factory=list)
    subgraphs: dict[str, Subgraph] | None = Field(
        default=None, description="subgraph definitions by name, used by nodes of type 'subgraph'"
    )
    ui: dict[str, Any] = Field(
        default_factory=dict, description="editor view data (viewport, comments, reroutes, …)"
    )

    @field_validator("subgraphs")
    @classmethod
    def _subgraph_names(cls, v: dict[str, Subgraph] | None) -> dict[str, Subgraph] | None:

        for name in v or {}:
            if not re.match(ID_PATTERN, name):
                raise ValueError(f"subgraph name '{name}' must be a letter or _ then letters, digits, _ - .")
        return v

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
