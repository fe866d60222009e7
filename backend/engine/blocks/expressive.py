"""Expressive operators (the paper's animation principles applied to a frame): mirror, asymmetry,
exaggeration and arcs (follow-through and delays, the overlapping action, are in `overlap`).

Every operator transforms the frame on its `in` port and passes through the channels it does not
touch, keeping the frame's events. All per-tick work is vectorised over channels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from backend.engine.blocks.base import (
    FRAME_OUT,
    BlockParams,
    DofSelection,
    Operator,
    Port,
    PortType,
    drivable,
    soft_range,
)
from backend.engine.embodiment import Dof, DofType, Embodiment
from backend.engine.frames import FrameHistory, PartialFrame
from backend.engine.selectors import channel_mask, find_pairs, pair_channels

# --------------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------------


def _continuous_dof(emb: Embodiment, name: str, what: str) -> Dof:
    if not emb.has_dof(name):
        raise ValueError(f"{what}: robot '{emb.name}' has no DoF '{name}'")
    d = emb.dof(name)
    if d.type is not DofType.continuous:
        raise ValueError(f"{what}: DoF '{name}' is {d.type.value}; a continuous DoF is needed")
    return d


def _alpha(dt: float, tau: float) -> float:
    """Exact first-order low-pass coefficient for a step of dt with time constant tau (0 = no lag)."""
    return 1.0 if tau <= 0.0 else 1.0 - math.exp(-dt / tau)


PairList = list[list[str]]


def _check_pairs(v: PairList) -> PairList:
    for pair in v:
        if len(pair) != 2 or pair[0] == pair[1]:
            raise ValueError(f"each pair is [left, right] with two different DoF names, got {pair}")
    return v


# --------------------------------------------------------------------------------------------------
# Mirror
# --------------------------------------------------------------------------------------------------


class MirrorParams(BlockParams):
    pairs: PairList = Field(
        default_factory=list,
        description="explicit [left, right] DoF pairs, in addition to those found by name",
    )
    auto_pair: bool = Field(
        default=True, description="pair DoFs by name: *_left/*_right, left_*/right_*, *_l/*_r"
    )
    negate: DofSelection = Field(
        default=["*yaw*", "*roll*"],
        description="DoFs whose deviation from rest flips sign (yaw/roll turn the other way)",
    )
    mix: float = drivable(
        Field(default=1.0, ge=0.0, le=1.0, description="0 = original, 1 = fully mirrored (blend in between)"),
        "overrides the mix parameter (0..1)",
        clamp="range",
    )

    @model_validator(mode="after")
    def _check(self) -> MirrorParams:
        _check_pairs(self.pairs)
        return self


class Mirror(Operator[MirrorParams]):
    """Mirrors a frame left/right: swaps paired DoFs and flips yaw/roll about the rest pose.

    Left/right pairs are found by name (ear_left/ear_right, left_arm/right_arm, eye_l/eye_r) or given
    explicitly; each side takes the other's deviation from its rest. DoFs matching `negate` (by default
    every yaw and roll) flip their deviation, so a head turn to the left becomes a turn to the right.
    `mix` blends from the original (0) to the mirrored frame (1); it can be driven by a signal.
    """

    type_name = "mirror"
    title = "Mirror left/right"

    def configure(self) -> None:
        emb = self.emb
        n = emb.n_channels
        left, right = pair_channels(find_pairs(emb, self.params.pairs, self.params.auto_pair))
        perm = np.arange(n)
        perm[left], perm[right] = right, left
        self.perm = perm
        self.sign = np.where(channel_mask(emb, self.params.negate, continuous_only=True), -1.0, 1.0)
        self.touched = (perm != np.arange(n)) | (self.sign < 0)

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        mix = self.driven(inputs).mix
        rest = self.emb.rest
        eff = np.where(frame.mask, frame.values, rest)
        mirrored = rest + self.sign * (eff - rest)[self.perm]
        blended = np.where(
            self.emb.enum_mask,
            np.where(mix >= 0.5, mirrored, frame.values),
            (1.0 - mix) * frame.values + mix * mirrored,
        )
        swapped_mask = frame.mask[self.perm]
        mask = np.where(self.touched, swapped_mask if mix >= 1.0 else (frame.mask | swapped_mask), frame.mask)
        values = np.where(self.touched, blended, frame.values)
        return {"out": PartialFrame(values, mask, frame.events)}


# --------------------------------------------------------------------------------------------------
# Asymmetry
# --------------------------------------------------------------------------------------------------

MAX_ASYM_DELAY = 1.0


class AsymmetryParams(BlockParams):
    offsets: dict[str, float] = Field(
        default_factory=dict, description="DoF name -> offset added (rad or m), e.g. one ear a bit lower"
    )
    gains: dict[str, float] = Field(
        default_factory=dict, description="DoF name -> gain on the deviation from rest (1 = unchanged)"
    )
    delay: float = drivable(
        Field(
            default=0.06,
            ge=0.0,
            le=MAX_ASYM_DELAY,
            description="lag of the right side of each left/right pair (s)",
        ),
        "overrides the delay parameter (s)",
        clamp="range",
    )
    pairs: PairList = Field(default_factory=list, description="explicit [left, right] DoF pairs")
    auto_pair: bool = Field(
        default=True, description="pair DoFs by name: *_left/*_right, left_*/right_*, *_l/*_r"
    )

    @model_validator(mode="after")
    def _check(self) -> AsymmetryParams:
        _check_pairs(self.pairs)
        for name, g in self.gains.items():
            if not (-3.0 <= g <= 3.0) or not math.isfinite(g):
                raise ValueError(f"gains['{name}'] = {g} is outside -3..3")
        for name, o in self.offsets.items():
            if not (-3.0 <= o <= 3.0) or not math.isfinite(o):
                raise ValueError(f"offsets['{name}'] = {o} rad is outside -3..3")
        return self


class Asymmetry(Operator[AsymmetryParams]):
    """Breaks robotic symmetry: per-DoF offsets and gains, and a small lag on the right side of pairs.

    Perfectly mirrored ears or eyelids look mechanical. This operator delays the right DoF of each
    left/right pair by `delay` seconds (a few tens of ms make paired motion organic), then scales each
    listed DoF's deviation from rest by its gain and adds its offset, clamped to the DoF's limits.
    """

    type_name = "asymmetry"
    title = "Asymmetry"
    State = FrameHistory

    def configure(self) -> None:
        emb = self.emb
        n = emb.n_channels
        _, right = pair_channels(find_pairs(emb, self.params.pairs, self.params.auto_pair))
        self.right = np.zeros(n, dtype=bool)
        self.right[right] = True
        self.gain = np.ones(n)
        self.offset = np.zeros(n)
        for name, g in self.params.gains.items():
            self.gain[_continuous_dof(emb, name, f"gains['{name}']").channels] = g
        for name, o in self.params.offsets.items():
            self.offset[_continuous_dof(emb, name, f"offsets['{name}']").channels] = o

    def reset(self) -> None:
        self.state = FrameHistory.for_delay(MAX_ASYM_DELAY, self.ctx.rate, self.emb.n_channels)

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        delay = self.driven(inputs).delay
        lag = np.where(self.right, round(delay * self.ctx.rate), 0)
        values, mask = self.state.push_read(frame.values, frame.mask, lag)
        rest, emb = self.emb.rest, self.emb
        shaped = np.clip(rest + self.gain * (values - rest) + self.offset, emb.min, emb.max)
        values = np.where(emb.continuous_mask & mask, shaped, values)
        return {"out": PartialFrame(values, mask, frame.events)}


# --------------------------------------------------------------------------------------------------
# Exaggerate
# --------------------------------------------------------------------------------------------------


class ExaggerateParams(BlockParams):
    dofs: DofSelection = Field(default=["stationary:*"])
    gain: float = drivable(
        Field(
            default=1.5,
            ge=0.0,
            le=3.0,
            description="scale of the deviation from the reference (1 = unchanged)",
        ),
        "overrides the gain parameter (0..3)",
        clamp="range",
    )
    reference: Literal["rest", "moving_average"] = Field(
        default="rest", description="deviation from the rest pose, or from a moving average of the input"
    )
    time_constant: float = Field(
        default=1.0,
        ge=0.01,
        le=30.0,
        description="moving-average time constant (s)",
        json_schema_extra=soft_range(0.01, 5, 0.01),
    )


class Exaggerate(Operator[ExaggerateParams]):
    """Exaggeration: scales each selected DoF's deviation from a reference, clamped to its limits.

    With reference `rest` a gain of 2 doubles every gesture's amplitude around the rest pose; with
    `moving_average` only the changes are amplified (the reference follows the input with the given
    time constant), so a held posture stays put while the motion around it grows. Gain 0..3 can be
    driven by a signal (e.g. from the emotion block's amplitude).
    """

    type_name = "exaggerate"
    title = "Exaggerate"

    @dataclass
    class State:
        avg: np.ndarray  # the moving average of the input (the reference in `moving_average` mode)
        primed: bool = False

    def configure(self) -> None:
        self.sel = channel_mask(self.emb, self.params.dofs, continuous_only=True)

    def reset(self) -> None:
        self.state = self.State(avg=self.emb.rest.copy())

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        gain = self.driven(inputs).gain
        emb, s = self.emb, self.state
        if self.params.reference == "rest":
            ref = emb.rest
        else:
            if not s.primed:
                s.avg = np.where(frame.mask, frame.values, s.avg)
                s.primed = True
            a = _alpha(dt, self.params.time_constant)
            s.avg = np.where(frame.mask, s.avg + a * (frame.values - s.avg), s.avg)
            ref = s.avg
        scaled = np.clip(ref + gain * (frame.values - ref), emb.min, emb.max)
        values = np.where(self.sel & frame.mask, scaled, frame.values)
        return {"out": PartialFrame(values, frame.mask, frame.events)}


# --------------------------------------------------------------------------------------------------
# Arc
# --------------------------------------------------------------------------------------------------


class ArcParams(BlockParams):
    primary: str = Field(
        default="head_yaw",
        description="DoF whose velocity drives the coupling",
        json_schema_extra={"x-widget": "dof"},
    )
    secondary: str = Field(
        default="head_pitch",
        description="DoF that receives the offset",
        json_schema_extra={"x-widget": "dof"},
    )
    gain: float = drivable(
        Field(
            default=0.08,
            ge=-2.0,
            le=2.0,
            description="offset on the secondary per primary speed (rad per rad/s)",
        ),
        "overrides the gain parameter (rad per rad/s)",
    )
    mode: Literal["abs", "signed"] = Field(
        default="abs",
        description="abs: same direction whatever way the primary moves (a dip); signed: follows its sign",
    )
    threshold: float = Field(
        default=0.0,
        ge=0.0,
        le=10.0,
        description="primary speed below which nothing is added (rad/s)",
        json_schema_extra=soft_range(0, 2, 0.01),
    )
    smoothing: float = Field(
        default=0.08,
        ge=0.0,
        le=2.0,
        description="time constant of the velocity smoothing (s)",
        json_schema_extra=soft_range(0, 1, 0.01),
    )

    @model_validator(mode="after")
    def _check(self) -> ArcParams:
        if self.primary == self.secondary:
            raise ValueError(f"primary and secondary must be different DoFs (both are '{self.primary}')")
        return self


class Arc(Operator[ArcParams]):
    """Arcs: couples a secondary DoF to the speed of a primary DoF, so straight moves become curved.

    The primary's velocity is estimated from the frame, smoothed, and `gain * speed` is added to the
    secondary (in `abs` mode the same way whatever direction, e.g. the head pitch dips during a large
    yaw turn; in `signed` mode with the primary's sign). Nothing is added while the primary is still.
    """

    type_name = "arc"
    title = "Arc"
    outputs = {**FRAME_OUT, "offset": Port(PortType.float, "offset currently added to the secondary (rad)")}

    @dataclass
    class State:
        prev: float | None = None  # the primary's last position
        vel: float = 0.0  # its smoothed velocity

    def configure(self) -> None:
        p = _continuous_dof(self.emb, self.params.primary, "primary")
        s = _continuous_dof(self.emb, self.params.secondary, "secondary")
        self.ip, self.is_ = p.channels.start, s.channels.start

    def without_input(self) -> dict[str, Any]:
        return {"out": self.empty(), "offset": 0.0}

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        p, s = self.params, self.state
        emb = self.emb
        x = (
            float(frame.values[self.ip])
            if frame.mask[self.ip]
            else (s.prev if s.prev is not None else float(emb.rest[self.ip]))
        )
        raw = 0.0 if s.prev is None or dt <= 0.0 else (x - s.prev) / dt
        s.prev = x
        s.vel += _alpha(dt, p.smoothing) * (raw - s.vel)
        speed = max(abs(s.vel) - p.threshold, 0.0)
        drive = speed if p.mode == "abs" else math.copysign(speed, s.vel)
        offset = self.driven(inputs).gain * drive
        values, mask = frame.values.copy(), frame.mask.copy()
        if offset != 0.0 or mask[self.is_]:
            base = values[self.is_] if mask[self.is_] else emb.rest[self.is_]
            values[self.is_] = min(max(base + offset, emb.min[self.is_]), emb.max[self.is_])
            mask[self.is_] = True
        return {"out": PartialFrame(values, mask, frame.events), "offset": offset}
