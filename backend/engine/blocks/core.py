"""Core blocks every program uses: the output, exposed inputs, the rest pose, a constant pose, a
sine source, gain/offset and DoF masks, and the stage-2 safety limiter."""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field

from backend.engine.blocks.base import (
    FRAME_IN,
    FRAME_OUT,
    Block,
    BlockParams,
    DofSelection,
    Operator,
    Port,
    PortRule,
    PortType,
    Role,
    SignalBlock,
    Source,
    drivable,
    soft_range,
)
from backend.engine.compiled import entry_point, plain_frame
from backend.engine.compiled.frames import (
    GAIN_OFFSET_SIG,
    HOLD_SIG,
    LIMITER_SIG,
    gain_offset_tick,
    hold_tick,
    limiter_tick,
)
from backend.engine.embodiment import DofType, Embodiment
from backend.engine.frames import PartialFrame
from backend.engine.selectors import SelectorError, channel_mask, select_dofs

# --------------------------------------------------------------------------------------------------
# Output and exposed inputs
# --------------------------------------------------------------------------------------------------


class OutputParams(BlockParams):
    pass


class Output(Block[OutputParams]):
    """The program's output: the Animation Frame sent to the robot.

    Channels the incoming frame does not set keep their last value (the rest pose at start), so a
    partial frame never snaps a DoF back. Every value is clamped to its DoF's position limits: whatever
    a program computes, the robot is never asked to leave its range. Every program has exactly one output.
    """

    type_name = "output"
    title = "Robot output"
    category = "output"
    role = Role.output
    inputs = {"in": Port(PortType.frame, "final frame", required=True)}
    outputs = {}

    @dataclass
    class State:
        held: np.ndarray  # the last value of every channel

    def configure(self) -> None:
        self._kernel = entry_point(hold_tick, HOLD_SIG) if self.ctx.compiled else None
        self._every = np.ones_like(
            self.emb.continuous_mask
        )  # the mask of every frame out (shared, read-only)

    def reset(self) -> None:
        self.state = self.State(held=self.emb.rest.copy())

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        frame: PartialFrame | None = inputs.get("in")
        held = self.state.held
        events = []
        if frame is not None:
            if self._kernel is not None and self.ctx.compiled and plain_frame(frame, self.emb.n_channels):
                self._kernel(frame.values, frame.mask, held, self.emb.min, self.emb.max)
            else:
                np.copyto(held, frame.values, where=frame.mask)
                np.clip(held, self.emb.min, self.emb.max, out=held)
            events = frame.events
        return {"frame": PartialFrame(held, self._every, events)}


SIGNAL_TYPES = Literal["float", "int", "bool", "string", "vec3", "colour", "event"]


class InputParams(BlockParams):
    name: str = Field(..., min_length=1, description="name of the program's exposed input to read")
    type: SIGNAL_TYPES = Field(default="float", description="signal type of the exposed input")


class ExposedInput(SignalBlock[InputParams]):
    """Reads one of the program's exposed inputs (e.g. `arousal`, `gaze_target`) as a signal.

    Exposed inputs are declared by the program with a type, default and range, and set at run time by
    an AI or the editor; the value changes only at tick boundaries.
    """

    type_name = "input"
    title = "Exposed input"
    outputs = {}
    port_rules = (
        PortRule(side="outputs", name="value", type="{type}", doc="current value of the exposed input"),
    )

    @classmethod
    def check(cls, params: InputParams, node: Any) -> None:
        """The program must declare the exposed input, with this type."""
        name, kind = params.name, params.type
        declared = node.read_input(name)
        if declared is None and name not in node.broken_inputs:
            names = list(node.exposed_inputs)
            hint = difflib.get_close_matches(name, names, n=1)
            extra = (
                f"; did you mean '{hint[0]}'?"
                if hint
                else f" (declared: {', '.join(sorted(names)) or 'none'})"
            )
            node.error(
                "unknown_exposed_input",
                port="name",
                at=("name",),
                message=f"node '{node.node_id}' reads exposed input '{name}', which the program "
                f"does not declare in 'inputs'{extra}",
            )
        elif declared is not None and declared.type != kind:
            node.error(
                "port_type_mismatch",
                port="type",
                at=("type",),
                ports_in_doubt=True,
                message=f"node '{node.node_id}' reads exposed input '{name}' as {kind}, but the "
                f"program declares it as {declared.type}",
            )

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        return {"value": self.ctx.inputs.get(self.params.name)}


# --------------------------------------------------------------------------------------------------
# Sources
# --------------------------------------------------------------------------------------------------


class RestPoseParams(BlockParams):
    dofs: DofSelection = Field(default=["*"])


class RestPose(Source[RestPoseParams]):
    """The robot's rest pose on the selected DoFs.

    A neutral base layer: under an additive idle layer it gives a robot that breathes around its rest.
    """

    type_name = "rest_pose"
    title = "Rest pose"

    def configure(self) -> None:
        self.mask = channel_mask(self.emb, self.params.dofs)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        return {"out": PartialFrame(self.emb.rest.copy(), self.mask, [])}


PoseValue = float | list[float] | str


def pose_vector(emb: Embodiment, values: dict[str, PoseValue]) -> tuple[np.ndarray, np.ndarray]:
    """Channel values and mask for a pose given as DoF name -> value.

    Continuous DoFs take a number, colour DoFs `[r, g, b]` in [0, 1], enum DoFs an option name or
    index. Values are clipped to the DoF's limits. Raises ValueError naming the DoF on bad input.
    """
    vec = emb.rest.copy()
    mask = np.zeros(emb.n_channels, dtype=bool)
    for name, value in values.items():
        if not emb.has_dof(name):
            raise SelectorError(name, f"robot '{emb.name}' has no DoF '{name}'")
        d = emb.dof(name)
        sl = d.channels
        if d.type is DofType.continuous:
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise ValueError(f"DoF '{name}' takes a finite number, got {value!r}")
            vec[sl] = min(max(float(value), d.min), d.max)
        elif d.type is DofType.colour:
            if not isinstance(value, (list, tuple)) or len(value) != 3:
                raise ValueError(f"DoF '{name}' takes a colour [r, g, b], got {value!r}")
            vec[sl] = np.clip(np.asarray(value, dtype=float), 0.0, 1.0)
        elif d.type is DofType.enum:
            options = d.options or ()
            if isinstance(value, str):
                if value not in options:
                    raise ValueError(f"DoF '{name}' has no option '{value}' (one of {list(options)})")
                vec[sl] = options.index(value)
            elif isinstance(value, (int, float)) and 0 <= int(value) < len(options):
                vec[sl] = int(value)
            else:
                raise ValueError(f"DoF '{name}' takes one of {list(options)}, got {value!r}")
        else:
            raise ValueError(f"DoF '{name}' is an event channel and has no pose value")
        mask[sl] = True
    return vec, mask


class PoseParams(BlockParams):
    values: dict[str, PoseValue] = Field(
        default_factory=dict,
        description="DoF name -> value (rad or m; [r,g,b] for colours; option name for expressions)",
        json_schema_extra={"x-widget": "pose"},
    )
    posture: str | None = Field(
        default=None,
        description="named posture of the robot, applied under `values`",
        json_schema_extra={"x-widget": "posture"},
    )


class Pose(Source[PoseParams]):
    """A constant pose: fixed values for some DoFs (and/or a named posture of the robot)."""

    type_name = "pose"
    title = "Constant pose"

    def configure(self) -> None:
        values: dict[str, PoseValue] = {}
        if self.params.posture:
            if self.params.posture not in self.emb.postures:
                raise ValueError(f"robot '{self.emb.name}' has no posture '{self.params.posture}'")
            values.update(self.emb.postures[self.params.posture])
        values.update(self.params.values)
        self.vec, self.mask = pose_vector(self.emb, values)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        return {"out": PartialFrame(self.vec.copy(), self.mask, [])}


class SineParams(BlockParams):
    dofs: DofSelection = Field(default=["stationary:*"])
    amplitude: float = drivable(
        Field(
            default=0.1,
            ge=0.0,
            le=10.0,
            description="peak deviation (rad or m)",
            json_schema_extra=soft_range(0, 1, 0.005),
        ),
        "overrides the amplitude parameter",
    )
    frequency: float = drivable(
        Field(
            default=0.25,
            ge=0.0,
            le=20.0,
            description="cycles per second (Hz)",
            json_schema_extra=soft_range(0, 3, 0.01),
        ),
        "overrides the frequency parameter",
    )
    phase: float = Field(default=0.0, ge=-2 * math.pi, le=2 * math.pi, description="phase at t=0 (rad)")
    phase_spread: float = Field(
        default=0.0,
        ge=-math.pi,
        le=math.pi,
        description="extra phase per selected DoF (rad), for wave-like motion",
    )
    offset: float = drivable(
        Field(
            default=0.0,
            ge=-10.0,
            le=10.0,
            description="added to the rest pose (rad or m)",
            json_schema_extra=soft_range(-1, 1, 0.01),
        ),
        "overrides the offset parameter",
    )


class Sine(Source[SineParams]):
    """A sine wave around the rest pose on the selected continuous DoFs.

    `rest + offset + amplitude * sin(2*pi*frequency*t + phase + i*phase_spread)`; the phase is
    integrated, so changing the frequency live never jumps. Amplitude, frequency and offset can be
    driven by signals.
    """

    type_name = "sine"
    title = "Sine"

    @dataclass
    class State:
        phi: float = 0.0  # integrated phase (rad)

    def configure(self) -> None:
        self.mask = channel_mask(self.emb, self.params.dofs, continuous_only=True)
        self.spread = np.zeros(self.emb.n_channels)
        self.spread[self.mask] = np.arange(int(self.mask.sum())) * self.params.phase_spread

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        d, s = self.driven(inputs), self.state
        values = self.emb.rest + d.offset + d.amplitude * np.sin(s.phi + self.params.phase + self.spread)
        s.phi = (s.phi + 2 * math.pi * d.frequency * dt) % (2 * math.pi)
        return {"out": PartialFrame(values, self.mask, [])}


# --------------------------------------------------------------------------------------------------
# Operators
# --------------------------------------------------------------------------------------------------


class GainOffsetParams(BlockParams):
    dofs: DofSelection = Field(default=["*"])
    gain: float = drivable(
        Field(
            default=1.0,
            ge=-10.0,
            le=10.0,
            description="scale of the deviation from the rest pose",
            json_schema_extra=soft_range(-2, 2, 0.01),
        )
    )
    offset: float = drivable(
        Field(
            default=0.0,
            ge=-10.0,
            le=10.0,
            description="added after scaling (rad or m)",
            json_schema_extra=soft_range(-1, 1, 0.01),
        )
    )


class GainOffset(Operator[GainOffsetParams]):
    """Scales each selected DoF's deviation from the rest pose and adds an offset.

    `rest + gain * (value - rest) + offset` on the selected continuous DoFs; other DoFs pass through.
    Gain and offset can be driven by signals.
    """

    type_name = "gain_offset"
    title = "Gain / offset"

    def configure(self) -> None:
        self.sel = channel_mask(self.emb, self.params.dofs, continuous_only=True)
        self._kernel = entry_point(gain_offset_tick, GAIN_OFFSET_SIG) if self.ctx.compiled else None

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        d = self.driven(inputs)
        rest = self.emb.rest
        if self._kernel is not None and self.ctx.compiled and plain_frame(frame, self.emb.n_channels):
            out = np.empty(self.emb.n_channels)
            self._kernel(frame.values, rest, self.sel, float(d.gain), float(d.offset), out)
            return {"out": PartialFrame(out, frame.mask, frame.events)}
        scaled = rest + d.gain * (frame.values - rest) + d.offset
        return {"out": PartialFrame(np.where(self.sel, scaled, frame.values), frame.mask, frame.events)}


class MaskParams(BlockParams):
    dofs: DofSelection = Field(default=["*"])
    mode: Literal["keep", "remove"] = Field(
        default="keep", description="keep only the selected DoFs, or remove them"
    )


class Mask(Operator[MaskParams]):
    """Keeps only the selected DoFs of a frame (or removes them); events follow their DoFs."""

    type_name = "mask"
    title = "Mask DoFs"

    def configure(self) -> None:
        sel = channel_mask(self.emb, self.params.dofs)
        keep = self.params.mode == "keep"
        self.keep = sel if keep else ~sel
        names = {d.name for d in self.emb.dofs}
        chosen = {d.name for d in select_dofs(self.emb, self.params.dofs)}
        self.event_dofs = chosen if keep else names - chosen

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        events = [e for e in frame.events if e.dof in self.event_dofs]
        return {"out": PartialFrame(frame.values, frame.mask & self.keep, events)}


# --------------------------------------------------------------------------------------------------
# Stage 2
# --------------------------------------------------------------------------------------------------


class SafetyParams(BlockParams):
    velocity_scale: float = Field(
        default=1.0, gt=0.0, le=1.0, description="fraction of each DoF's velocity limit allowed (0..1]"
    )
    margin: float = Field(
        default=0.0, ge=0.0, le=0.5, description="fraction of each DoF's range kept free at both ends"
    )


class SafetyLimiter(Block[SafetyParams]):
    """Keeps every DoF within its position limits and slews it at most at its velocity limit.

    The last line of defence before the robot: whatever the program does, each continuous channel
    stays inside [min + margin, max - margin] and moves at most `velocity_scale * velocity` per second.
    Channels the incoming frame does not set hold their last value.
    """

    type_name = "safety_limiter"
    title = "Safety limiter"
    category = "stage2"
    role = Role.stage2
    can_bypass = False  # the robot's guard is never switched off from the editor (see blocks/bypass.py)
    inputs = FRAME_IN
    outputs = FRAME_OUT

    @dataclass
    class State:
        last: np.ndarray  # the last output (held where the frame sets nothing)

    def configure(self) -> None:
        e = self.emb
        span = np.where(e.continuous_mask, e.max - e.min, 0.0)
        self.lo = e.min + self.params.margin * span
        self.hi = e.max - self.params.margin * span
        self.vmax = np.where(e.continuous_mask, e.vel_limit * self.params.velocity_scale, np.inf)
        self._kernel = entry_point(limiter_tick, LIMITER_SIG) if self.ctx.compiled else None
        self._every = np.ones(e.n_channels, dtype=bool)  # the mask of every frame out (shared, read-only)

    def reset(self) -> None:
        self.state = self.State(last=self.emb.rest.copy())

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        frame: PartialFrame | None = inputs.get("in")
        s = self.state
        if (
            self._kernel is not None
            and self.ctx.compiled
            and (frame is None or plain_frame(frame, self.emb.n_channels))
        ):
            if frame is None:
                self._kernel(
                    s.last, self.emb.continuous_mask, False, s.last, self.lo, self.hi, self.vmax, float(dt)
                )
            else:
                self._kernel(frame.values, frame.mask, True, s.last, self.lo, self.hi, self.vmax, float(dt))
            return {
                "out": PartialFrame(s.last.copy(), self._every, frame.events if frame is not None else [])
            }
        target = s.last if frame is None else np.where(frame.mask, frame.values, s.last)
        target = np.clip(target, self.lo, self.hi)
        step = self.vmax * dt
        s.last = s.last + np.clip(target - s.last, -step, step)
        return {"out": PartialFrame(s.last.copy(), self._every, frame.events if frame is not None else [])}
