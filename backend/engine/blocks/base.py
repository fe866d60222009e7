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

Register a block class with `@register_block`. Every module of this package is imported by
`backend.engine.blocks`, so a new block needs no other edit.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import math
from dataclasses import dataclass, field
from enum import StrEnum
from types import SimpleNamespace
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from pydantic.fields import FieldInfo

# Port types and the wiring rule live in `ports`; they are re-exported here, where blocks import them.
from backend.engine.blocks.ports import (  # noqa: F401
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


# Parameter annotations that the editor renders with dedicated widgets.
DofSelection = Annotated[
    list[str],
    Field(
        description="DoF selectors: names, globs (head_*), dimensions (stationary:*) or *",
        json_schema_extra={"x-widget": "dofs"},
    ),
]


# --------------------------------------------------------------------------------------------------
# Signal values and drivable parameters
# --------------------------------------------------------------------------------------------------


def vec3_or_none(value: Any) -> np.ndarray | None:
    """A finite 3-vector from a vec3 signal, or None when it is missing or not finite."""
    if value is None:
        return None
    if type(value) in (list, tuple) and len(value) == 3:  # the common case, without numpy's conversions
        a, b, c = value
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and isinstance(c, (int, float)):
            a, b, c = float(a), float(b), float(c)
            return np.array((a, b, c)) if math.isfinite(a) and math.isfinite(b) and math.isfinite(c) else None
    try:
        v = np.array(value, dtype=float).reshape(-1)  # a copy: contiguous, and never the sender's array
    except (TypeError, ValueError):
        return None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        return None
    return v


def colour_or_none(value: Any) -> np.ndarray | None:
    """A colour [r, g, b] with components in [0, 1] from a signal or command, or None when it is not one."""
    c = vec3_or_none(value)
    if c is None:
        return None
    r, g, b = c.tolist()  # three Python comparisons beat two numpy reductions on 3 numbers
    return c if 0.0 <= r <= 1.0 and 0.0 <= g <= 1.0 and 0.0 <= b <= 1.0 else None


def _number(value: Any) -> Any:
    """A wired number, or None when it is missing or not finite (NaN/inf never override a parameter)."""
    if isinstance(value, (float, int)) and not math.isfinite(value):
        return None
    return value


# What a wired value of each port type must be to override its parameter (None: not usable).
_USABLE = {
    PortType.vec3: vec3_or_none,
    PortType.colour: colour_or_none,
    PortType.float: _number,
    PortType.int: _number,
}

Clamp = Literal["range", "floor"]


@dataclass(frozen=True)
class Drive:
    """Marks a parameter as drivable (see `drivable`); kept in the pydantic field's metadata, which the
    JSON Schema does not show."""

    doc: str = ""
    port: PortType = PortType.float
    clamp: Clamp | None = None


def drivable(
    field_info: FieldInfo, doc: str = "", *, port: PortType = PortType.float, clamp: Clamp | None = None
) -> Any:
    """Declare a parameter drivable by a signal: `amplitude: float = drivable(Field(...), "overrides …")`.

    The block then has an input port of the parameter's name, type `port` and doc `doc`, and
    `Block.driven(inputs)` resolves the parameter each tick: a connected, usable signal (a finite number,
    a valid vec3 or colour) overrides it. `clamp="range"` keeps a wired number within the field's
    `ge`/`le` bounds, `clamp="floor"` only above its `ge` bound; without `clamp` it is taken as it is.
    """
    field_info.metadata.append(Drive(doc, port, clamp))
    return field_info


@dataclass(frozen=True)
class DrivenParam:
    """One drivable parameter of a block class: its port, and how a wired value replaces it."""

    name: str
    port: Port
    lo: float | None = None
    hi: float | None = None

    @classmethod
    def of(cls, name: str, info: FieldInfo, drive: Drive) -> DrivenParam:
        lo = hi = None
        if drive.clamp is not None:
            lo = next((m.ge for m in info.metadata if getattr(m, "ge", None) is not None), None)  # Field(ge=)
            hi = next((m.le for m in info.metadata if getattr(m, "le", None) is not None), None)  # Field(le=)
            if lo is None or (drive.clamp == "range" and hi is None):
                raise TypeError(f"drivable parameter '{name}' has clamp={drive.clamp!r} but no ge/le bounds")
            if drive.clamp == "floor":
                hi = None
        return cls(name, Port(drive.port, drive.doc), lo, hi)

    def resolve(self, wired: Any, fallback: Any) -> Any:
        """The wired value when it is usable, else `fallback`; numbers as float/int, clamped as declared."""
        kind = self.port.type
        if (
            type(wired) is float and kind is PortType.float and math.isfinite(wired)
        ):  # the common case, shortly
            lo, hi = self.lo, self.hi
            return (
                wired
                if lo is None and hi is None
                else min(max(wired, -math.inf if lo is None else lo), math.inf if hi is None else hi)
            )
        usable = _USABLE.get(kind)
        value = wired if usable is None else usable(wired)
        if value is None:
            if kind in (PortType.vec3, PortType.colour):  # as an array, like a wired one, when it is valid
                converted = usable(fallback)
                return fallback if converted is None else converted
            value = fallback
        if value is None or kind not in (PortType.float, PortType.int):
            return value
        value = float(value) if kind is PortType.float else int(value)
        if self.lo is not None:
            value = max(value, self.lo)
        if self.hi is not None:
            value = min(value, self.hi)
        return value


def driven_params(params_model: type[BaseModel]) -> dict[str, DrivenParam]:
    """The drivable parameters of a parameter model, in field order."""
    out = {}
    for name, info in params_model.model_fields.items():
        drive = next((m for m in info.metadata if isinstance(m, Drive)), None)
        if drive is not None:
            out[name] = DrivenParam.of(name, info, drive)
    return out


class _Unset:
    """The fallback of a drivable parameter `driven` was not given one for."""


_UNSET = _Unset()
_PLAIN = frozenset({type(None), float, int, bool, str, _Unset})
_NUMBERS = frozenset({float, int, bool})
_COMPARED_PORTS = frozenset({PortType.float, PortType.int, PortType.vec3, PortType.colour})


class _DrivenMemo:
    """What `Block.driven` keeps between calls for one parameter object: the parameters resolved with
    nothing wired, and the last call's key (wired values, then fallbacks) with its result.

    A key equal to the last one gives the last result when that is sure to be what resolving it again
    would give: every drivable port is a number or vector port (whose values are converted, so 1, 1.0
    and True resolve alike), and every item of the last key was a plain value (None, a number, a string)
    or a list or tuple of numbers (kept as a tuple: a producer may change its list in place, and compared
    as the vector ports' own cache does); a number equal to zero must also have the same sign (-0.0 == 0 ==
    0.0, an int zero counting as +0.0). Any other key (an array, …) is resolved anew."""

    __slots__ = (
        "exact",
        "floats",
        "key",
        "lists",
        "name_set",
        "names",
        "ns",
        "params",
        "ports_compared",
        "static",
        "static_ns",
        "zeros",
    )

    def __init__(self, params: BaseModel, drivables: dict[str, DrivenParam]):
        self.params = params
        self.names = tuple(drivables)
        self.name_set = frozenset(self.names)
        self.static = {name: d.resolve(None, getattr(params, name)) for name, d in drivables.items()}
        self.static_ns = SimpleNamespace(**self.static)
        self.ports_compared = all(d.port.type in _COMPARED_PORTS for d in drivables.values())
        # When every parameter is a float port: per parameter (its DrivenParam, the parameter's value, and the
        # clamp bounds as `resolve` applies them to a finite float: None without a clamp, else lo/hi or ∓inf).
        self.floats = None
        if all(d.port.type is PortType.float for d in drivables.values()):
            self.floats = tuple(
                (d, getattr(params, name), None, None)
                if d.lo is None and d.hi is None
                else (
                    d,
                    getattr(params, name),
                    -math.inf if d.lo is None else d.lo,
                    math.inf if d.hi is None else d.hi,
                )
                for name, d in drivables.items()
            )
        self.key, self.lists, self.zeros, self.exact, self.ns = None, False, None, False, None

    def hit(self, key: tuple) -> bool:
        """Whether `key` (a `driven` key) resolves to the last result."""
        if not self.exact:
            return False
        if self.lists:
            key = tuple([tuple(v) if type(v) is list else v for v in key])
        try:
            return key == self.key and (self.zeros is None or _zero_signs(key) == self.zeros)
        except (ValueError, TypeError):  # an array compared with a number
            return False

    def remember(self, key: tuple, result: SimpleNamespace) -> None:
        exact, lists, zeros = self.ports_compared, False, False
        for value in key:
            kind = type(value)
            if kind in _NUMBERS:
                zeros = zeros or value == 0
            elif kind is list or kind is tuple:
                lists = lists or kind is list
                exact = exact and all(type(x) in _NUMBERS for x in value)
            elif kind not in _PLAIN:
                exact = False
        if lists:
            key = tuple([tuple(v) if type(v) is list else v for v in key])
        self.key, self.lists, self.exact, self.ns = key, lists, exact, result
        self.zeros = _zero_signs(key) if exact and zeros else None


def _zero_signs(key: tuple) -> list[float]:
    """The signs of a key's numbers equal to zero, in order (an int or bool zero counts as +0.0)."""
    return [math.copysign(1.0, v) for v in key if type(v) in _NUMBERS and v == 0]


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
    inputs: dict[str, Any] = field(default_factory=dict)
    resources: Any = None
    seed: int = 0
    events: list[dict[str, Any]] = field(default_factory=list)  # block -> engine notifications
    compiled: bool = field(default_factory=default_compiled)

    def notify(self, node: str, kind: str, **data: Any) -> None:
        """Report a block event (e.g. clip completed) to the engine, which forwards it to clients."""
        self.events.append({"node": node, "event": kind, **data})


class BlockCommandError(ValueError):
    """A command a block cannot carry out (unknown clip, bad argument); the message says why."""


def state_fits(fresh: Any, old: Any) -> bool:
    """Whether `old` state can replace `fresh`: the same class, and every array of `fresh` matched by an
    array of the same shape (parameters may have changed the DoF set or a buffer's length)."""
    if type(old) is not type(fresh):
        return False
    for f in dataclasses.fields(fresh):
        mine = getattr(fresh, f.name)
        if isinstance(mine, np.ndarray):
            theirs = getattr(old, f.name)
            if not isinstance(theirs, np.ndarray) or theirs.shape != mine.shape:
                return False
    return True


def copy_state(state: Any) -> Any:
    """A copy of a state object whose arrays are copied too (other values are shared)."""
    out = copy.copy(state)
    for f in dataclasses.fields(state):
        value = getattr(state, f.name)
        if isinstance(value, np.ndarray):
            setattr(out, f.name, value.copy())
    return out


class Block:
    type_name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    category: ClassVar[str] = "operators"  # one of catalog.CATEGORIES
    role: ClassVar[Role] = Role.operator
    doc: ClassVar[str] = ""
    Params: ClassVar[type[BlockParams]] = BlockParams
    inputs: ClassVar[dict[str, Port]] = {}  # the declared ports, then one per drivable parameter
    outputs: ClassVar[dict[str, Port]] = {}
    drivables: ClassVar[dict[str, DrivenParam]] = {}
    # Ports derived from the parameters, after the ones above (see `PortRule`).
    port_rules: ClassVar[tuple[PortRule, ...]] = ()
    _declared_inputs: ClassVar[dict[str, Port]] = {}
    # The run-time state: a dataclass; `reset()` puts a fresh instance at `self.state`.
    State: ClassVar[type | None] = None
    state: Any

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        declared = cls.__dict__.get("inputs", cls._declared_inputs)
        cls._declared_inputs = declared
        cls.drivables = driven_params(cls.Params)
        clash = sorted(declared.keys() & cls.drivables.keys())
        if clash:
            raise TypeError(f"{cls.__name__}: ports {clash} are declared by hand and as drivable parameters")
        cls.inputs = {**declared, **{name: d.port for name, d in cls.drivables.items()}}
        if "ports" in cls.__dict__:
            raise TypeError(
                f"{cls.__name__}: derive ports with `port_rules`, which the editor applies too, "
                f"instead of overriding ports()"
            )

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
            "port_rules": [rule.model_dump() for rule in cls.port_rules],
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
        """Return to the initial state: a fresh `State()` (override when it starts from the robot, …)."""
        if self.State is not None:
            self.state = self.State()

    def update_params(self, params: BlockParams) -> None:
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
            memo = self._driven_memo = _DrivenMemo(params, self.drivables)
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
            # What `_DrivenMemo.remember` works out, on the way: plain items only (exact), any float zero.
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
        self, key: tuple, fallbacks: dict[str, Any], memo: _DrivenMemo, params: BlockParams
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


class Operator(Block):
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


class Source(Block):
    """A block that creates a frame (on `out`) from its parameters, inputs and state."""

    category = "sources"
    role = Role.source
    outputs = FRAME_OUT


class SignalBlock(Block):
    """A block that computes scalar signals (exposed inputs, math, oscillators, mappings)."""

    category = "signals"
    role = Role.signal


def _schema_defaults(params_model: type[BaseModel]) -> dict[str, Any]:
    """Parameter defaults as the JSON Schema gives them (what the editor starts a new block with)."""
    props = params_model.model_json_schema().get("properties", {})
    return {name: prop["default"] for name, prop in props.items() if "default" in prop}


BLOCKS: dict[str, type[Block]] = {}


def register_block(cls: type[Block]) -> type[Block]:
    """Class decorator adding a block type to the registry (type names are unique)."""
    if not cls.type_name:
        raise TypeError(f"{cls.__name__} has no type_name")
    if cls.type_name in BLOCKS and BLOCKS[cls.type_name] is not cls:
        raise TypeError(
            f"block type '{cls.type_name}' registered twice ({BLOCKS[cls.type_name].__name__}, {cls.__name__})"
        )
    if not cls.doc and cls.__doc__:  # the class docstring is the doc the editor shows
        cls.doc = inspect.cleandoc(cls.__doc__)
    BLOCKS[cls.type_name] = cls
    return cls
