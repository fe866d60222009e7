"""Sources for the display dimension: LEDs and face expressions.

The LED and face blocks set display DoFs (a colour, an enum option). The audible dimension's blocks
(speech, sounds) are in backend.engine.blocks.audible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator

from backend.engine.blocks.base import (
    BlockCommandError,
    BlockParams,
    PortType,
    Source,
    colour_or_none,
    drivable,
)
from backend.engine.blocks.cells import cell
from backend.engine.blocks.quiet import QuietWhenIdle
from backend.engine.embodiment import Dimension, Dof, DofType, Embodiment
from backend.engine.frames import PartialFrame, SteadyFrame


def resolve_dof(emb: Embodiment, name: str | None, want: DofType, what: str, kind: str | None = None) -> Dof:
    """The named DoF (checked to be of type `want`, and audible `kind`), or the robot's first such DoF."""

    def fits(d: Dof) -> bool:
        return d.type is want and (kind is None or d.kind == kind)

    label = f"{kind} " if kind else f"{want.value} "
    if name:
        if not emb.has_dof(name):
            raise ValueError(f"{what}: robot '{emb.name}' has no DoF '{name}'")
        d = emb.dof(name)
        if not fits(d):
            raise ValueError(f"{what}: DoF '{name}' is not a {label}DoF")
        return d
    found = next(
        (d for d in emb.dofs if fits(d) and (want is not DofType.enum or d.dimension is Dimension.display)),
        None,
    )
    if found is None:
        raise ValueError(f"{what}: robot '{emb.name}' has no {label}DoF")
    return found


def _colour(value: Any, where: str) -> np.ndarray:
    """A colour [r, g, b] with components in [0, 1]; raises BlockCommandError naming `where`."""
    c = colour_or_none(value)
    if c is None:
        raise BlockCommandError(f"{where}: a colour is [r, g, b] with components in 0..1, got {value!r}")
    return c


# --------------------------------------------------------------------------------------------------
# LED
# --------------------------------------------------------------------------------------------------


class LedParams(BlockParams):
    dof: str | None = Field(
        default=None,
        description="colour DoF (LED or LED group); default: the robot's first",
        json_schema_extra={"x-widget": "dof"},
    )
    colour: list[float] = drivable(
        Field(
            default=[1.0, 1.0, 1.0],
            min_length=3,
            max_length=3,
            description="colour [r, g, b], components 0..1",
            json_schema_extra={"x-widget": "colour"},
        ),
        "overrides the colour [r, g, b]",
        port=PortType.colour,
    )
    mode: Literal["solid", "pulse", "breathe"] = Field(
        default="solid",
        description="solid; pulse (a quick flash then a fade, like a heartbeat); breathe (a slow sine)",
    )
    frequency: float = drivable(
        Field(default=0.5, ge=0.0, le=10.0, description="pulses or breaths per second (Hz)"),
        "overrides the frequency (Hz)",
        clamp="floor",
    )
    depth: float = drivable(
        Field(
            default=0.5, ge=0.0, le=1.0, description="how far the brightness dips (0 = none, 1 = to black)"
        ),
        "overrides the depth (0..1)",
        clamp="range",
    )

    @field_validator("colour")
    @classmethod
    def _range(cls, v: list[float]) -> list[float]:
        if not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in v):
            raise ValueError(f"colour components must be within 0..1, got {v}")
        return v


def _components(colour: Any) -> list[float]:
    """A resolved colour's components as Python floats."""
    if type(colour) is np.ndarray and colour.ndim == 1:
        return colour.tolist()
    return np.asarray(colour, dtype=float).ravel().tolist()


def brightness(mode: str, u: float, depth: float) -> float:
    """Brightness factor in [1 - depth, 1] at phase u in [0, 1) (cycles)."""
    if mode == "breathe":
        return 1.0 - depth * (0.5 - 0.5 * math.cos(2.0 * math.pi * u))
    if mode == "pulse":
        attack = 0.12
        level = 0.5 - 0.5 * math.cos(math.pi * u / attack) if u < attack else math.exp(-5.0 * (u - attack))
        return (1.0 - depth) + depth * level
    return 1.0


class Led(Source[LedParams]):
    """Sets an LED (a colour DoF) to a colour, solid, pulsing or breathing.

    The colour comes from the `colour` input when connected, else from the last `set_led` command, else
    from the parameter. Pulse and breathe modulate the brightness by `depth` at `frequency` Hz; every
    component stays within 0..1.
    """

    type_name = "led"
    title = "LED"

    @dataclass
    class State:
        # the pulse/breath phase (cycles) in a one-element array: the compiled core steps it in place
        phase: np.ndarray = field(default_factory=lambda: np.zeros(1))
        commanded: np.ndarray | None = None  # the colour of the last set_led command

        cycles = cell("phase", 0, "The pulse/breath phase (cycles).")

    def configure(self) -> None:
        self.dof = resolve_dof(self.emb, self.params.dof, DofType.colour, "led")
        self.mask = np.zeros(self.emb.n_channels, dtype=bool)
        self.mask[self.dof.channels] = True

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "set_led":
            dof = args.get("dof")
            if dof and dof != self.dof.name:
                raise BlockCommandError(f"led '{self.node_id}' drives '{self.dof.name}', not '{dof}'")
            self.state.commanded = _colour(args.get("colour"), "set_led")
            return {"dof": self.dof.name, "colour": [float(c) for c in self.state.commanded]}
        return super().handle(command, args)

    def fallback_colour(self) -> Any:
        """The colour when none is wired (or the wired one is malformed): the last command's, else the
        parameter (the same object until one of them changes)."""
        commanded = self.state.commanded
        return commanded if commanded is not None else self.params.colour

    def resolve(self, inputs: dict[str, Any], fallback: Any) -> tuple[Any, list[float]]:
        """This tick's drivable parameters (`driven`) and colour components: a wired colour wins, a
        malformed one falls back to `fallback`. (The compiled core's LED op calls it too.)"""
        if "colour" in inputs:
            d = self.driven(inputs, colour=fallback)
            return d, _components(d.colour)
        # unwired, the colour is the fallback's, converted once per command or parameter change
        seen = self.__dict__.get("_fallback")
        if seen is None or seen[0] is not fallback:
            colour = self.drivables["colour"].resolve(None, fallback)
            seen = self._fallback = (fallback, _components(colour))
        return self.driven(inputs), seen[1]

    def advance(self, frequency: float, dt: float) -> float:
        """This tick's phase (cycles, 0..1), then the phase stepped by `frequency` (Hz) over `dt` (s).
        (The compiled core's kernel steps the same `state.phase` alike: core/vm.py's LED op.)"""
        s = self.state
        u = s.cycles % 1.0
        s.cycles = (s.cycles + frequency * dt) % 1.0
        return u

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        d, rgb = self.resolve(inputs, self.fallback_colour())
        factor = brightness(self.params.mode, self.advance(d.frequency, dt), d.depth)
        values = self.emb.rest.copy()
        # np.clip(colour * factor, 0, 1) on three numbers, without numpy's per-call cost: comparisons
        # (the same result as min(max(v, 0), 1), NaN and -0.0 included), element by element (a list
        # into a slice costs a conversion to an array)
        c = self.dof.channels.start
        for v in rgb:
            v *= factor
            values[c] = 0.0 if v < 0.0 else 1.0 if v > 1.0 else v
            c += 1
        return {"out": PartialFrame(values, self.mask, [])}


# --------------------------------------------------------------------------------------------------
# Face
# --------------------------------------------------------------------------------------------------


class FaceParams(BlockParams):
    dof: str | None = Field(
        default=None,
        description="enum display DoF (face/screen); default: the robot's first",
        json_schema_extra={"x-widget": "dof"},
    )
    expression: str | None = drivable(
        Field(default=None, description="option to show; default: the DoF's rest option"),
        "overrides the expression (an option name)",
        port=PortType.string,
    )


class Face(QuietWhenIdle, Source[FaceParams]):
    """Shows a face/screen expression: one option of an enum display DoF (smile, frown, …).

    The expression comes from the `expression` input when connected (unknown names are ignored), else
    from the last `set_face` command, else from the parameter. Unknown expressions in the parameter or
    a command are errors that list the DoF's options.
    """

    type_name = "face"
    title = "Face expression"

    @dataclass
    class State:
        commanded: int | None = None  # the option index of the last set_face command

    def configure(self) -> None:
        self.dof = resolve_dof(self.emb, self.params.dof, DofType.enum, "face")
        self.options = list(self.dof.options or ())
        self.channel = self.dof.channels.start
        self.mask = np.zeros(self.emb.n_channels, dtype=bool)
        self.mask[self.channel] = True
        if self.params.expression is None:
            self.default_index = round(float(self.emb.rest[self.channel]))
        else:
            self.default_index = self._index(self.params.expression, ValueError)

    def _index(self, name: Any, error: type[Exception]) -> int:
        if not isinstance(name, str) or name not in self.options:
            raise error(f"face: DoF '{self.dof.name}' has no expression {name!r} (options: {self.options})")
        return self.options.index(name)

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "set_face":
            dof = args.get("dof")
            if dof and dof != self.dof.name:
                raise BlockCommandError(f"face '{self.node_id}' drives '{self.dof.name}', not '{dof}'")
            self.state.commanded = self._index(args.get("expression"), BlockCommandError)
            return {"dof": self.dof.name, "expression": self.options[self.state.commanded]}
        return super().handle(command, args)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        commanded = self.state.commanded
        index = commanded if commanded is not None else self.default_index
        # unknown names are ignored; unconnected, the expression resolves to None
        wired = self.driven(inputs, expression=None).expression if "expression" in inputs else None
        if isinstance(wired, str) and wired in self.options:
            index = self.options.index(wired)
        self.quiet = True  # a function of the command, parameters and input (quiet.py)
        shown = self.__dict__.get("_shown")  # one frame per expression shown (frames are read-only)
        if shown is None or shown[0] != index or shown[1].mask is not self.mask:
            values = self.emb.rest.copy()
            values[self.channel] = index
            shown = self._shown = (index, SteadyFrame(values, self.mask, []))
        return {"out": shown[1]}
