"""Animation Blocks: the units an Animation Program is wired from.

A block is a small class with
- `type_name`, `title`, `category` (palette group), `role` (what it is in the APU) and `doc`
  (first line: a one-line summary; the rest: the paragraph the editor shows);
- `Params`: a pydantic model (`BlockParams`) whose JSON Schema drives the editor's parameter panel and
  the program validator (units in field descriptions, ranges as `ge`/`le`);
- typed `inputs` / `outputs` ports (`Port`): `frame` ports carry PAFs, the others scalar signals;
  `ports(params)` may derive them from the parameters (the layer mixer has one input per layer);
- explicit internal state, created by `reset()` and advanced by `tick(dt, inputs) -> outputs`.

Conventions
- `configure()` derives cached data from `self.params` (resolved DoF masks, …); it runs at creation
  and after `update_params`, and must not touch state, so a parameter change never causes a jump.
- State lives in the attributes named in `state_attrs`; `adopt_state(old)` copies them from the block
  of the same id and type in the program being replaced (a hot swap keeps a playing clip playing).
- A signal input that is connected overrides the parameter of the same name (see `signal`).
- `handle(command)` receives run-time commands (play, seek, set layer, …) addressed to the block.
- `check(params, node)` / `check_wiring(params, node)` add the block type's own rules to the program
  checks (`backend.graph.checks.hooks`), so the checker never names a block type.
- Hot paths are vectorised over channels; never loop over DoFs in `tick`.

Register a block class with `@register_block`. Every module of this package is imported by
`backend.engine.blocks`, so a new block needs no other edit.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from backend.engine.embodiment import Embodiment
from backend.engine.frames import PartialFrame


class PortType(str, Enum):
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


class Role(str, Enum):
    """What a block is in the APU (the paper's Level 0-3 pipeline)."""

    source = "source"  # creates a PAF
    operator = "operator"  # transforms a PAF
    mixer = "mixer"  # blends layers (Level 2)
    stage2 = "stage2"  # post-processes the whole frame (Level 3)
    output = "output"  # the program's single output
    signal = "signal"  # computes scalar signals (exposed inputs, math, LFOs)


@dataclass(frozen=True)
class Port:
    type: PortType
    doc: str = ""
    required: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type.value, "doc": self.doc, "required": self.required}


class BlockParams(BaseModel):
    """Base of every block's parameter model: unknown parameters are errors, never ignored."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)


# Parameter annotations that the editor renders with dedicated widgets.
DofSelection = Annotated[
    list[str],
    Field(
        description="DoF selectors: names, globs (head_*), dimensions (stationary:*) or *",
        json_schema_extra={"x-widget": "dofs"},
    ),
]


@dataclass
class BlockContext:
    """What a block may know of the world: the robot, the tick rate, exposed inputs and resources.

    `inputs` is the live dict of the program's exposed input values (written by commands at tick
    boundaries, read by `input` blocks). `resources` gives access to clips and postures on disk.
    """

    embodiment: Embodiment
    rate: float
    inputs: dict[str, Any] = field(default_factory=dict)
    resources: Any = None
    seed: int = 0
    events: list[dict[str, Any]] = field(default_factory=list)  # block -> engine notifications

    def notify(self, node: str, kind: str, **data: Any) -> None:
        """Report a block event (e.g. clip completed) to the engine, which forwards it to clients."""
        self.events.append({"node": node, "event": kind, **data})


class BlockCommandError(ValueError):
    """A command a block cannot carry out (unknown clip, bad argument); the message says why."""


class Block:
    type_name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    category: ClassVar[str] = "operators"  # sources | operators | layers | stage2 | signals | output
    role: ClassVar[Role] = Role.operator
    doc: ClassVar[str] = ""
    Params: ClassVar[type[BlockParams]] = BlockParams
    inputs: ClassVar[dict[str, Port]] = {}
    outputs: ClassVar[dict[str, Port]] = {}
    state_attrs: ClassVar[tuple[str, ...]] = ()

    def __init__(self, params: BlockParams, ctx: BlockContext, node_id: str = ""):
        self.params = params
        self.ctx = ctx
        self.node_id = node_id or self.type_name
        self.emb = ctx.embodiment
        self.configure()
        self.reset()

    # --- description ----------------------------------------------------------------------------
    @classmethod
    def ports(cls, params: BlockParams | None = None) -> tuple[dict[str, Port], dict[str, Port]]:
        """Input and output ports for these parameters (static for most blocks)."""
        return cls.inputs, cls.outputs

    @classmethod
    def summary(cls) -> str:
        return cls.doc.strip().splitlines()[0] if cls.doc.strip() else cls.title

    @classmethod
    def describe(cls) -> dict[str, Any]:
        """The registry entry: what the editor's palette and the API's /blocks show."""
        ins, outs = cls.ports(None)
        return {
            "type": cls.type_name,
            "title": cls.title or cls.type_name,
            "category": cls.category,
            "role": cls.role.value,
            "summary": cls.summary(),
            "doc": " ".join(cls.doc.split()),
            "params_schema": cls.Params.model_json_schema(),
            "inputs": {k: p.to_dict() for k, p in ins.items()},
            "outputs": {k: p.to_dict() for k, p in outs.items()},
            "dynamic_ports": _has_dynamic_ports(cls),
        }

    # --- program checks (called by backend.graph.checks; `node` is its NodeCheck) ----------------
    @classmethod
    def check(cls, params: BlockParams, node: Any) -> None:
        """Rules of this block type beyond its parameter model, checked before it is configured.

        Report with `node.error(code, message, port=..., at=<path in params>)`; default: none.
        """

    @classmethod
    def check_wiring(cls, params: BlockParams, node: Any) -> None:
        """Warnings once the program's edges are known (`node.connected(port)`); default: none."""

    # --- life cycle -----------------------------------------------------------------------------
    def configure(self) -> None:
        """Derive cached data from `self.params`. Must not reset state."""

    def reset(self) -> None:
        """Return to the initial state."""

    def update_params(self, params: BlockParams) -> None:
        """Apply new parameters live, keeping state (a slider drag never causes a jump by itself)."""
        self.params = params
        self.configure()

    def adopt_state(self, old: "Block") -> None:
        """Take over the state of the block this one replaces in a hot swap (same id and type).

        Arrays whose shape changed with the new parameters keep their fresh value.
        """
        for name in self.state_attrs:
            if not hasattr(old, name):
                continue
            value = getattr(old, name)
            mine = getattr(self, name, None)
            if isinstance(mine, np.ndarray) and (not isinstance(value, np.ndarray) or value.shape != mine.shape):
                continue
            setattr(self, name, value.copy() if isinstance(value, np.ndarray) else value)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        """Advance by `dt` seconds and return the outputs by port name."""
        raise NotImplementedError

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        """Carry out a run-time command addressed to this block; raise BlockCommandError if unknown."""
        raise BlockCommandError(f"block '{self.node_id}' ({self.type_name}) does not take command '{command}'")

    # --- helpers --------------------------------------------------------------------------------
    def signal(self, inputs: dict[str, Any], name: str, default: Any) -> Any:
        """A connected signal input overrides the parameter of the same name; NaN/inf are ignored."""
        value = inputs.get(name)
        if value is None:
            return default
        if isinstance(value, (float, int)) and not math.isfinite(value):
            return default
        return value

    def empty(self) -> PartialFrame:
        return PartialFrame.empty(self.emb.n_channels)


def _has_dynamic_ports(cls: type[Block]) -> bool:
    return cls.ports.__func__ is not Block.ports.__func__  # type: ignore[attr-defined]


BLOCKS: dict[str, type[Block]] = {}


def register_block(cls: type[Block]) -> type[Block]:
    """Class decorator adding a block type to the registry (type names are unique)."""
    if not cls.type_name:
        raise TypeError(f"{cls.__name__} has no type_name")
    if cls.type_name in BLOCKS and BLOCKS[cls.type_name] is not cls:
        raise TypeError(f"block type '{cls.type_name}' registered twice ({BLOCKS[cls.type_name].__name__}, {cls.__name__})")
    if not cls.doc and cls.__doc__:  # the class docstring is the doc the editor shows
        cls.doc = inspect.cleandoc(cls.__doc__)
    BLOCKS[cls.type_name] = cls
    return cls
