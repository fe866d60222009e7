"""Signal values and drivable parameters: what a wired signal must be to override a parameter, and how
`Block.driven` resolves every drivable parameter each tick.

- `vec3_or_none` / `colour_or_none` turn a signal into a vector or colour, or None when it is not one;
- `drivable(Field(...), "port doc")` marks a parameter as drivable (`Drive`), `driven_params` lists a
  parameter model's drivable parameters (`DrivenParam`: its port, clamp bounds and `resolve`);
- `DrivenMemo` is what `Block.driven` keeps between ticks so that a tick whose wired values equal the
  last one's costs a comparison, not a resolution (most ticks of a program see unchanged signals).

These are re-exported by `backend.engine.blocks.base`, where blocks import them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from operator import is_
from types import SimpleNamespace
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from backend.engine.blocks.ports import Port, PortType


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
    field_info: Any, doc: str = "", *, port: PortType = PortType.float, clamp: Clamp | None = None
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
            # a vector (or colour) fallback as an array, like a wired one, when it is valid
            if usable is not None and kind in (PortType.vec3, PortType.colour):
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


class DrivenMemo:
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
        # clamp bounds as `resolve` applies them to a finite float: lo None without a clamp, else lo/hi or ∓inf).
        self.floats: tuple[tuple[DrivenParam, Any, float | None, float], ...] | None = None
        if all(d.port.type is PortType.float for d in drivables.values()):
            self.floats = tuple(
                (d, getattr(params, name), None, math.inf)
                if d.lo is None and d.hi is None
                else (
                    d,
                    getattr(params, name),
                    -math.inf if d.lo is None else d.lo,
                    math.inf if d.hi is None else d.hi,
                )
                for name, d in drivables.items()
            )
        # `ns` is the last result (read only once `exact`; the static one until then)
        self.key, self.lists, self.zeros, self.exact, self.ns = None, False, None, False, self.static_ns

    def hit(self, key: tuple) -> bool:
        """Whether `key` (a `driven` key) resolves to the last result."""
        if not self.exact:
            return False
        if self.lists:
            key = tuple([tuple(v) if type(v) is list else v for v in key])
        last = self.key
        try:
            if last is None or key != last:
                return False
            # a zero's sign counts; the same objects have it (an exposed input's value is one object)
            return self.zeros is None or all(map(is_, key, last)) or _zero_signs(key) == self.zeros
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
