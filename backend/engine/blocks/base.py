"""Animation Blocks: the units an Animation Program is wired from.

A block is a small class with
- `type_name`, `title`, `category` (palette group), `role` (what it is in the APU) and `doc`
  (first line: a one-line summary; the rest: the paragraph the editor shows);
- `Params`: a pydantic model (`BlockParams`) whose JSON Schema drives the editor's parameter panel and
  the program validator (units in field descriptions, ranges as `ge`/`le`);
- typed `inputs` / `outputs` ports (`Port`): `frame` ports carry PAFs, the others scalar signals;
  `port_rules` derive more ports from the parameters (the layer mixer has one input per layer), as
  data the editor applies too (`backend.engine.blocks.ports`), so `ports(params)` is never overridden;
- explicit internal state, created by `reset()` and advanced by `tick(dt, inputs) -> outputs`.

Conventions
- `configure()` derives cached data from `self.params` (resolved DoF masks, …); it runs at creation
  and after `update_params`, and must not touch state, so a parameter change never causes a jump.
- A parameter declared with `drivable(Field(...), "port doc")` is also an input port of the same name
  (added after the ports the class declares); `self.driven(inputs)` gives, each tick, every drivable
  parameter resolved: the wired value when one is connected and usable, else the parameter.
- State lives in one object, `self.state`, an instance of the block's `State` dataclass made by
  `reset()`; `adopt_state(old)` takes the old block's state over as a whole in a hot swap (same id and
  type), unless one of its arrays changed shape (a hot swap keeps a playing clip playing).
- `Operator` is the base of blocks that transform the frame on their `in` port (it handles a missing
  input frame once for all of them); `Source` and `SignalBlock` give sources and signal blocks their
  category and role.
- `handle(command)` receives run-time commands (play, seek, set layer, …) addressed to the block.
- `check(params, node)` / `check_wiring(params, node)` add the block type's own rules to the program
  checks (`backend.graph.checks.hooks`), so the checker never names a block type.
- Hot paths are vectorised over channels; never loop over DoFs in `tick` (or compile the tick, keeping
  the numpy code as its reference: `backend.engine.compiled`).
- A block never changes the frames and values it receives, nor what `driven` returns: arrays are
  shared between blocks and from tick to tick.

A block type is registered by an entry point (backend.plugins), named after its `type_name`, in the
pyproject.toml of its distribution (this project's, or a plugin package's):

    [project.entry-points."nutty.blocks"]
    sway = "backend.engine.blocks.sway:Sway"

then `pip install -e .`. Defining or importing the class registers nothing.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from enum import StrEnum
from types import SimpleNamespace
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Generic, TypeVar, get_args

from pydantic import BaseModel, ConfigDict, Field

from backend.engine.blocks.block_state import copy_state, counted, counting, state_fits

# Drivable parameters and signal values live in `driven`; re-exported here, where blocks import them.
from backend.engine.blocks.driven import (  # noqa: F401 (re-exported: the names were importable from here before the split)
    _NUMBERS,
    _PLAIN,
    _UNSET,
    Clamp,
    Drive,
    DrivenMemo,
    DrivenParam,
    _number,
    _zero_signs,
    colour_or_none,
    drivable,
    driven_params,
    vec3_or_none,
)
from backend.engine.blocks.input_values import InputValues

# Port types and the wiring rule live in `ports`; they are re-exported here, where blocks import them.
from backend.engine.blocks.ports import (  # noqa: F401 (re-exported: the names were importable from here before the split)
    COMPATIBLE_SIGNALS,
    Port,
    PortRule,
    PortType,
    derive_ports,
    port_accepts,
)
from backend.engine.compiled import default_compiled
from backend.engine.embodiment import Embodiment
from backend.engine.frames import PartialFrame
from backend.engine.library import Resources
from backend.safe_json import validation_bytes


class Role(StrEnum):
    """What a block is in the APU (the paper's Level 0-3 pipeline)."""

    source = "source"  # creates a PAF
    operator = "operator"  # transforms a PAF
    mixer = "mixer"  # blends layers (Level 2)
    stage2 = "stage2"  # post-processes the whole frame (Level 3)
    output = "output"  # the program's single output
    signal = "signal"  # computes scalar signals (exposed inputs, math, LFOs)


FRAME_IN = {"in": Port(PortType.frame, "frame to transform", required=True)}
FRAME_OUT = {"out": Port(PortType.frame, "resulting frame")}


class BlockParams(BaseModel):
    """Base of every block's parameter model: unknown parameters are errors, never ignored."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)

    @classmethod
    def from_json_value(cls, raw: Any) -> BlockParams:
        """Parameters from a program document's JSON value, validated strictly as JSON: a number must be
        a JSON number (not true, not "0.3"), a list a JSON array; nothing is coerced."""
        return cls.model_validate_json(validation_bytes(raw), strict=True)


def soft_range(lo: float, hi: float, step: float | None = None) -> dict[str, Any]:
    """A number parameter's `json_schema_extra`: the range (and step) the editor's slider spans, inside
    its hard `ge`/`le` bounds. Typing may still go beyond it up to the hard bounds; the engine reads
    only the hard ones."""
    return {"x-soft": [lo, hi], **({"x-step": step} if step is not None else {})}


# Parameter annotations that the editor renders with dedicated widgets.
DofSelection = Annotated[
    list[str],
    Field(
        description="DoF selectors: names, globs (head_*), dimensions (stationary:*) or *",
        json_schema_extra={"x-widget": "dofs"},
    ),
]


# --------------------------------------------------------------------------------------------------
# Context and blocks
# --------------------------------------------------------------------------------------------------


@dataclass
class BlockContext:
    """What a block may know of the world: the robot, the tick rate, exposed inputs and resources.

    `inputs` is the live dict of the program's exposed input values (written by commands at tick
    boundaries, read by `input` blocks). `resources` gives access to clips and postures on disk.
    `compiled`: blocks with a compiled kernel use it (False: their numpy reference; see
    `backend.engine.compiled`).
    """

    embodiment: Embodiment
    rate: float
    inputs: dict[str, Any] = field(default_factory=InputValues)  # (its changes counted: input_values.py)
    resources: Resources | None = None
    seed: int = 0
    events: list[dict[str, Any]] = field(default_factory=list)  # block -> engine notifications
    compiled: bool = field(default_factory=default_compiled)

    def notify(self, node: str, kind: str, **data: Any) -> None:
        """Report a block event (e.g. clip completed) to the engine, which forwards it to clients."""
        self.events.append({"node": node, "event": kind, **data})


class BlockCommandError(ValueError):
    """A command a block cannot carry out (unknown clip, bad argument); the message says why."""


P = TypeVar("P", bound="BlockParams")


def _params_argument(cls: type) -> type[BlockParams] | None:
    """The parameter model a class names as its type argument (`class Lfo(SignalBlock[LfoParams])`)."""
    for base in cls.__dict__.get("__orig_bases__", ()):
        for arg in get_args(base):
            if isinstance(arg, type) and issubclass(arg, BlockParams):
                return arg
    return None


class Block(Generic[P]):
    """The base of every block, generic over its parameter model `P`: `self.params` is a `P`.

    A block names its model once, as the type argument (`class Lfo(SignalBlock[LfoParams])`), which
    also sets `Params`, the model the validator and the editor's panel read.
    """

    type_name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    category: ClassVar[str] = "operators"  # one of catalog.CATEGORIES
    role: ClassVar[Role] = Role.operator
    doc: ClassVar[str] = ""
    # Whether a program may bypass it (frame in -> frame out unchanged; see blocks/bypass.py).
    can_bypass: ClassVar[bool] = True
    bypassed: ClassVar[bool] = False  # True on the pass-through subclass a bypassed node runs
    Params: ClassVar[type[BlockParams]] = BlockParams
    inputs: ClassVar[dict[str, Port]] = {}  # the declared ports, then one per drivable parameter
    outputs: ClassVar[dict[str, Port]] = {}
    drivables: ClassVar[dict[str, DrivenParam]] = {}
    # Ports derived from the parameters, after the ones above (see `PortRule`).
    port_rules: ClassVar[tuple[PortRule, ...]] = ()
    _declared_inputs: ClassVar[dict[str, Port]] = {}
    # The run-time state: a dataclass; `reset()` puts a fresh instance at `self.state`.
    State: ClassVar[type | None] = None
    if TYPE_CHECKING:
        state: Any  # (None: a block without run-time state)
        params: P
    else:  # replacing either is counted, for the compiled core (blocks/block_state.py)
        state, params = counted("state"), counted("params")
    _state: Any = None
    _wired_cache: dict[str, tuple[tuple[Any, ...], BlockParams, Any]]  # driven(): last vector per param

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        named = _params_argument(cls)
        if named is not None and "Params" not in cls.__dict__:
            cls.Params = named
        declared = cls.__dict__.get("inputs", cls._declared_inputs)
        cls._declared_inputs = declared
        cls.drivables = driven_params(cls.Params)
        clash = sorted(declared.keys() & cls.drivables.keys())
        if clash:
            raise TypeError(f"{cls.__name__}: ports {clash} are declared by hand and as drivable parameters")
        cls.inputs = {**declared, **{name: d.port for name, d in cls.drivables.items()}}
        own = cls.__dict__.get("handle")
        if own is not None:  # commands counted, for the compiled core (blocks/block_state.py)
            setattr(cls, "handle", counting(own))  # noqa: B010 - assigning a method: type checkers reject `cls.handle =`
        if "ports" in cls.__dict__:
            raise TypeError(
                f"{cls.__name__}: derive ports with `port_rules`, which the editor applies too, "
                f"instead of overriding ports()"
            )

    def __init__(self, params: P, ctx: BlockContext, node_id: str = ""):
        self.params = params
        self.ctx = ctx
        self.node_id = node_id or self.type_name
        self.emb = ctx.embodiment
        self.configure()
        self.reset()

    # --- description ----------------------------------------------------------------------------
    @classmethod
    def ports(cls, params: BlockParams | None = None) -> tuple[dict[str, Port], dict[str, Port]]:
        """Input and output ports for these parameters (static for most blocks); without parameters,
        a rule over a list parameter gives no port and the others follow the parameters' defaults."""
        if not cls.port_rules:
            return cls.inputs, cls.outputs
        if params is None:
            return derive_ports(cls.port_rules, None, _schema_defaults(cls.Params), cls.inputs, cls.outputs)
        return derive_ports(cls.port_rules, params.model_dump(mode="json"), {}, cls.inputs, cls.outputs)

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
            "dynamic_ports": bool(cls.port_rules),
            "bypassable": cls.bypassable(),
            "port_rules": [rule.model_dump() for rule in cls.port_rules],
        }

    @classmethod
    def bypassable(cls) -> bool:
        """Whether a program may bypass this block: it takes a frame and gives one (an operator, a
        mixer or a stage-2 block) and does not guard the robot (`can_bypass`)."""
        return cls.role in (Role.operator, Role.mixer, Role.stage2) and cls.can_bypass

    # --- program checks (called by backend.graph.checks; `node` is its NodeCheck) ----------------
    @classmethod
    def check(cls, params: P, node: Any) -> None:
        """Rules of this block type beyond its parameter model, checked before it is configured.

        Report with `node.error(code, message, port=..., at=<path in params>)`; default: none.
        """

    @classmethod
    def check_wiring(cls, params: P, node: Any) -> None:
        """Warnings once the program's edges are known (`node.connected(port)`); default: none."""

    # --- life cycle -----------------------------------------------------------------------------
    def configure(self) -> None:
        """Derive cached data from `self.params`. Must not reset state."""

    def reset(self) -> None:
        """Return to the initial state: a fresh `State()` (override when it starts from the robot, …)."""
        if self.State is not None:
            self.state = self.State()

    def update_params(self, params: P) -> None:
        """Apply new parameters live, keeping state (a slider drag never causes a jump by itself)."""
        self.params = params
        self.configure()

    def adopt_state(self, old: Block) -> None:
        """Take over the state of the block this one replaces in a hot swap (same id and type).

        The state is taken as a whole (arrays copied), unless an array in it changed shape with the new
        parameters: then the fresh state stays.
        """
        mine = getattr(self, "state", None)
        theirs = getattr(old, "state", None)
        if mine is not None and theirs is not None and state_fits(mine, theirs):
            self.state = copy_state(theirs)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        """Advance by `dt` seconds and return the outputs by port name."""
        raise NotImplementedError

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        """Carry out a run-time command addressed to this block; raise BlockCommandError if unknown."""
        raise BlockCommandError(
            f"block '{self.node_id}' ({self.type_name}) does not take command '{command}'"
        )

    # --- helpers --------------------------------------------------------------------------------
    def driven(self, inputs: dict[str, Any], **fallbacks: Any) -> SimpleNamespace:
        """Every drivable parameter for this tick, by name: the wired value when its input is connected
        and usable, else the parameter, or the fallback given here (e.g. a value set by a command).
        Treat the values as read-only (arrays may be shared between ticks), and the namespace too: a call
        with the same wired values and fallbacks as the last one returns the last one's namespace."""
        params = self.params
        memo = self.__dict__.get("_driven_memo")
        if memo is None or memo.params is not params:
            memo = self._driven_memo = DrivenMemo(params, self.drivables)
        names, get = memo.names, inputs.get
        if fallbacks:
            if not memo.name_set.issuperset(fallbacks):
                unknown = fallbacks.keys() - memo.name_set
                raise TypeError(
                    f"{type(self).__name__}.driven: {sorted(unknown)} are not drivable parameters"
                )
            given = fallbacks.get
            if len(names) == 1:
                key = (get(names[0]), given(names[0], _UNSET))
            else:
                key = tuple([get(name) for name in names] + [given(name, _UNSET) for name in names])
        elif memo.name_set.isdisjoint(inputs):
            return memo.static_ns  # nothing wired, nothing given: the parameters themselves, resolved once
        elif len(names) == 1:
            key = (get(names[0]),)
        elif len(names) == 2:
            key = (get(names[0]), get(names[1]))
        else:
            key = tuple([get(name) for name in names])
        if memo.hit(key):
            return memo.ns
        if memo.floats is not None and not fallbacks:
            # Number parameters only: `DrivenParam.resolve`'s shortcut for a finite float inline, the rest by it.
            # What `DrivenMemo.remember` works out, on the way: plain items only (exact), any float zero.
            values, plain, zeros = memo.static.copy(), True, False
            for name, wired, (d, raw, lo, hi) in zip(names, key, memo.floats):
                if wired is None:
                    continue
                if type(wired) is float and math.isfinite(wired):
                    values[name] = wired if lo is None else min(max(wired, lo), hi)
                    zeros = zeros or wired == 0.0
                else:
                    values[name] = d.resolve(wired, raw)
                    plain = plain and type(wired) in _PLAIN
                    zeros = zeros or (type(wired) in _NUMBERS and wired == 0)
            result = SimpleNamespace(**values)
            memo.key, memo.lists, memo.exact, memo.ns = key, False, plain, result
            memo.zeros = _zero_signs(key) if plain and zeros else None
            return result
        result = self._resolve_driven(key, fallbacks, memo, params)
        memo.remember(key, result)
        return result

    def _resolve_driven(
        self, key: tuple, fallbacks: dict[str, Any], memo: DrivenMemo, params: BlockParams
    ) -> SimpleNamespace:
        """`driven` worked out for `key` (its wired values first): the static values, then per parameter
        the wired value resolved against the fallback given (or the parameter) when it is usable."""
        values = memo.static.copy()
        drivables = self.drivables
        for name, wired in zip(memo.names, key):
            if name in fallbacks:
                values[name] = drivables[name].resolve(wired, fallbacks[name])  # the fallback when unwired
            elif wired is None:
                continue
            elif type(wired) in (list, tuple):  # a vector signal: converted again only when it changes
                vec, seen = tuple(wired), self.__dict__.setdefault("_wired_cache", {}).get(name)
                if seen is None or seen[1] is not params or seen[0] != vec:
                    seen = self._wired_cache[name] = (
                        vec,
                        params,
                        drivables[name].resolve(wired, getattr(params, name)),
                    )
                values[name] = seen[2]
            else:
                values[name] = drivables[name].resolve(wired, getattr(params, name))
        return SimpleNamespace(**values)

    def signal(self, inputs: dict[str, Any], name: str, default: Any) -> Any:
        """A signal input that is not a parameter (e.g. the mixer's layer weights), or `default` when it
        is unconnected; NaN/inf are ignored."""
        value = _number(inputs.get(name))
        return default if value is None else value

    def empty(self) -> PartialFrame:
        return PartialFrame.empty(self.emb.n_channels)


class Operator(Block[P]):
    """A block that transforms the frame on its `in` port into the frame on its `out` port.

    With no frame on `in` (nothing upstream this tick) it outputs `without_input()` (an empty frame)
    and its state stands still; otherwise `transform` does the work.
    """

    category = "operators"
    role = Role.operator
    inputs = FRAME_IN
    outputs = FRAME_OUT

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        frame: PartialFrame | None = inputs.get("in")
        if frame is None:
            return self.without_input()
        return self.transform(dt, frame, inputs)

    def without_input(self) -> dict[str, Any]:
        """The outputs when no frame arrives on `in`."""
        return {"out": self.empty()}

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        """Advance by `dt` with `frame` on `in` (and the other inputs); return the outputs by port name."""
        raise NotImplementedError


class Source(Block[P]):
    """A block that creates a frame (on `out`) from its parameters, inputs and state."""

    category = "sources"
    role = Role.source
    outputs = FRAME_OUT


class SignalBlock(Block[P]):
    """A block that computes scalar signals (exposed inputs, math, oscillators, mappings)."""

    category = "signals"
    role = Role.signal


def _schema_defaults(params_model: type[BaseModel]) -> dict[str, Any]:
    """Parameter defaults as the JSON Schema gives them (what the editor starts a new block with)."""
    props = params_model.model_json_schema().get("properties", {})
    return {name: prop["default"] for name, prop in props.items() if "default" in prop}


BLOCKS: dict[str, type[Block]] = {}


def register_block(cls: type[Block], registry: dict[str, type[Block]] | None = None) -> type[Block]:
    """Add a block type to `registry` (default BLOCKS; type names are unique). The plugin loader calls it
    for every `nutty.blocks` entry point (`backend.engine.blocks.reload`)."""
    blocks = BLOCKS if registry is None else registry
    if not (isinstance(cls, type) and issubclass(cls, Block)):
        raise TypeError(f"{cls!r} is not a Block subclass")
    if not cls.type_name:
        raise TypeError(f"{cls.__name__} has no type_name")
    if cls.type_name in blocks and blocks[cls.type_name] is not cls:
        raise TypeError(
            f"block type '{cls.type_name}' registered twice ({blocks[cls.type_name].__name__}, {cls.__name__})"
        )
    if not cls.doc and cls.__doc__:  # the class docstring is the doc the editor shows
        cls.doc = inspect.cleandoc(cls.__doc__)
    blocks[cls.type_name] = cls
    return cls
