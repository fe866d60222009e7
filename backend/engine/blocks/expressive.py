"""Expressive operators (the paper's animation principles applied to a frame): mirror, asymmetry,
exaggeration, arcs, follow-through and delays (overlapping action).

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
    register_block,
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
    auto_pair: bool = Field(True, description="pair DoFs by name: *_left/*_right, left_*/right_*, *_l/*_r")
    negate: DofSelection = Field(
        default=["*yaw*", "*roll*"],
        description="DoFs whose deviation from rest flips sign (yaw/roll turn the other way)",
    )
    mix: float = drivable(
        Field(1.0, ge=0.0, le=1.0, description="0 = original, 1 = fully mirrored (blend in between)"),
        "overrides the mix parameter (0..1)",
        clamp="range",
    )

    @model_validator(mode="after")
    def _check(self) -> MirrorParams:
        _check_pairs(self.pairs)
        return self


@register_block
class Mirror(Operator):
    """Mirrors a frame left/right: swaps paired DoFs and flips yaw/roll about the rest pose.

    Left/right pairs are found by name (ear_left/ear_right, left_arm/right_arm, eye_l/eye_r) or given
    explicitly; each side takes the other's deviation from its rest. DoFs matching `negate` (by default
    every yaw and roll) flip their deviation, so a head turn to the left becomes a turn to the right.
    `mix` blends from the original (0) to the mirrored frame (1); it can be driven by a signal.
    """

    type_name = "mirror"
    title = "Mirror left/right"
    Params = MirrorParams

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
            0.06, ge=0.0, le=MAX_ASYM_DELAY, description="lag of the right side of each left/right pair (s)"
        ),
        "overrides the delay parameter (s)",
        clamp="range",
    )
    pairs: PairList = Field(default_factory=list, description="explicit [left, right] DoF pairs")
    auto_pair: bool = Field(True, description="pair DoFs by name: *_left/*_right, left_*/right_*, *_l/*_r")

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


@register_block
class Asymmetry(Operator):
    """Breaks robotic symmetry: per-DoF offsets and gains, and a small lag on the right side of pairs.

    Perfectly mirrored ears or eyelids look mechanical. This operator delays the right DoF of each
    left/right pair by `delay` seconds (a few tens of ms make paired motion organic), then scales each
    listed DoF's deviation from rest by its gain and adds its offset, clamped to the DoF's limits.
    """

    type_name = "asymmetry"
    title = "Asymmetry"
    Params = AsymmetryParams
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
        Field(1.5, ge=0.0, le=3.0, description="scale of the deviation from the reference (1 = unchanged)"),
        "overrides the gain parameter (0..3)",
        clamp="range",
    )
    reference: Literal["rest", "moving_average"] = Field(
        "rest", description="deviation from the rest pose, or from a moving average of the input"
    )
    time_constant: float = Field(1.0, ge=0.01, le=30.0, description="moving-average time constant (s)")


@register_block
class Exaggerate(Operator):
    """Exaggeration: scales each selected DoF's deviation from a reference, clamped to its limits.

    With reference `rest` a gain of 2 doubles every gesture's amplitude around the rest pose; with
    `moving_average` only the changes are amplified (the reference follows the input with the given
    time constant), so a held posture stays put while the motion around it grows. Gain 0..3 can be
    driven by a signal (e.g. from the emotion block's amplitude).
    """

    type_name = "exaggerate"
    title = "Exaggerate"
    Params = ExaggerateParams

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
        "head_yaw",
        description="DoF whose velocity drives the coupling",
        json_schema_extra={"x-widget": "dof"},
    )
    secondary: str = Field(
        "head_pitch", description="DoF that receives the offset", json_schema_extra={"x-widget": "dof"}
    )
    gain: float = drivable(
        Field(0.08, ge=-2.0, le=2.0, description="offset on the secondary per primary speed (rad per rad/s)"),
        "overrides the gain parameter (rad per rad/s)",
    )
    mode: Literal["abs", "signed"] = Field(
        "abs",
        description="abs: same direction whatever way the primary moves (a dip); signed: follows its sign",
    )
    threshold: float = Field(
        0.0, ge=0.0, le=10.0, description="primary speed below which nothing is added (rad/s)"
    )
    smoothing: float = Field(0.08, ge=0.0, le=2.0, description="time constant of the velocity smoothing (s)")

    @model_validator(mode="after")
    def _check(self) -> ArcParams:
        if self.primary == self.secondary:
            raise ValueError(f"primary and secondary must be different DoFs (both are '{self.primary}')")
        return self


@register_block
class Arc(Operator):
    """Arcs: couples a secondary DoF to the speed of a primary DoF, so straight moves become curved.

    The primary's velocity is estimated from the frame, smoothed, and `gain * speed` is added to the
    secondary (in `abs` mode the same way whatever direction, e.g. the head pitch dips during a large
    yaw turn; in `signed` mode with the primary's sign). Nothing is added while the primary is still.
    """

    type_name = "arc"
    title = "Arc"
    Params = ArcParams
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


# --------------------------------------------------------------------------------------------------
# Follow-through
# --------------------------------------------------------------------------------------------------


def spring_step_matrix(freq: float, zeta: float, dt: float) -> np.ndarray:
    """Exact 2x2 transition of a damped spring's (error, velocity) over dt (input held over the step).

    e'' = -w^2 e - 2 zeta w e', with e = position - target. Exact for any dt, so the response has the
    same shape at every tick rate and is unconditionally stable.
    """
    w = 2.0 * math.pi * freq
    decay = math.exp(-zeta * w * dt)
    if 1.0 - zeta < 1e-6:  # critical damping
        return decay * np.array([[1.0 + w * dt, dt], [-w * w * dt, 1.0 - w * dt]])
    wd = w * math.sqrt(1.0 - zeta * zeta)
    c, s = math.cos(wd * dt), math.sin(wd * dt)
    return decay * np.array([[c + zeta * w * s / wd, s / wd], [-w * w * s / wd, c - zeta * w * s / wd]])


class FollowThroughParams(BlockParams):
    dofs: DofSelection = Field(default=["stationary:*"])
    enabled: bool = Field(
        False, description="off by default: overshoot moves the robot beyond the programmed pose"
    )
    frequency: float = Field(2.0, ge=0.1, le=20.0, description="natural frequency of the spring (Hz)")
    damping: float = Field(0.3, ge=0.05, le=1.0, description="damping ratio (1 = critical, no overshoot)")
    max_overshoot: float = Field(
        0.15, ge=0.0, le=1.0, description="largest distance from the input the output may reach (rad or m)"
    )


@register_block
class FollowThrough(Operator):
    """Follow-through: a damped spring on the selected DoFs, so they overshoot and settle after a stop.

    Each selected DoF follows its input through an under-damped spring (natural frequency and damping
    ratio), integrated exactly so it behaves the same at any tick rate. Because overshoot takes the robot
    beyond the programmed pose, the block is disabled by default (then it passes the frame through
    exactly); when enabled the output never strays more than `max_overshoot` from the input and stays
    within the DoF's limits.
    """

    type_name = "follow_through"
    title = "Follow-through"
    Params = FollowThroughParams

    @dataclass
    class State:
        x: np.ndarray  # the spring's position
        v: np.ndarray  # its velocity
        target: np.ndarray  # the last input
        primed: bool = False

    def configure(self) -> None:
        self.sel = channel_mask(self.emb, self.params.dofs, continuous_only=True)
        self._matrix_key: tuple | None = None

    def reset(self) -> None:
        rest = self.emb.rest
        self.state = self.State(x=rest.copy(), v=np.zeros(self.emb.n_channels), target=rest.copy())

    def _matrix(self, dt: float) -> np.ndarray:
        key = (self.params.frequency, self.params.damping, dt)
        if key != self._matrix_key:
            self._matrix_key, self._m = key, spring_step_matrix(*key)
        return self._m

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        u = np.where(frame.mask, frame.values, s.target)
        if not s.primed:
            s.x, s.target, s.primed = u.copy(), u.copy(), True
        u_vel = (u - s.target) / dt if dt > 0 else np.zeros_like(u)
        s.target = u
        if not self.params.enabled or dt <= 0:
            s.x, s.v = u.copy(), u_vel  # track the input, so enabling later never jumps
            return {"out": PartialFrame(frame.values, frame.mask, frame.events)}
        m = self._matrix(dt)
        e = s.x - u
        e_new = m[0, 0] * e + m[0, 1] * s.v
        v_new = m[1, 0] * e + m[1, 1] * s.v
        lim = self.params.max_overshoot
        clipped = np.clip(e_new, -lim, lim)
        v_new = np.where(clipped != e_new, u_vel, v_new)  # held at the bound: move with the input
        emb = self.emb
        x_new = np.clip(u + clipped, emb.min, emb.max)
        v_new = np.where(x_new != u + clipped, 0.0, v_new)  # at a position limit: stop there
        s.x = np.where(self.sel, x_new, u)
        s.v = np.where(self.sel, v_new, u_vel)
        values = np.where(self.sel & frame.mask, s.x, frame.values)
        return {"out": PartialFrame(values, frame.mask, frame.events)}


# --------------------------------------------------------------------------------------------------
# Delay / overlap
# --------------------------------------------------------------------------------------------------

MAX_DELAY = 2.0


class DelayParams(BlockParams):
    dofs: DofSelection = Field(default=["*"])
    delay: float = Field(0.1, ge=0.0, le=MAX_DELAY, description="delay of the selected DoFs (s)")
    delays: dict[str, float] = Field(
        default_factory=dict, description="DoF name -> its own delay (s, 0..2), overriding `delay`"
    )

    @model_validator(mode="after")
    def _check(self) -> DelayParams:
        for name, d in self.delays.items():
            if not (0.0 <= d <= MAX_DELAY):
                raise ValueError(f"delays['{name}'] = {d} s is outside 0..{MAX_DELAY}")
        return self


@register_block
class Delay(Operator):
    """Delays the selected DoFs by a fixed time, for overlapping action (one part moves after another).

    Put it on the layer that drives the ears, say, with 0.15 s: the ears follow the head's motion a
    moment later instead of in lock-step. Each DoF can have its own delay; unselected DoFs and events
    pass through at once. The delay is rounded to whole ticks.
    """

    type_name = "delay"
    title = "Delay / overlap"
    Params = DelayParams
    State = FrameHistory

    def configure(self) -> None:
        emb = self.emb
        sel = channel_mask(emb, self.params.dofs)
        seconds = np.where(sel, self.params.delay, 0.0)
        for name, d in self.params.delays.items():
            if not emb.has_dof(name):
                raise ValueError(f"delays: robot '{emb.name}' has no DoF '{name}'")
            seconds[emb.dof(name).channels] = d
        self.lag = np.rint(seconds * self.ctx.rate).astype(np.intp)

    def reset(self) -> None:
        self.state = FrameHistory.for_delay(MAX_DELAY, self.ctx.rate, self.emb.n_channels)

    def transform(self, dt: float, frame: PartialFrame, inputs: dict[str, Any]) -> dict[str, Any]:
        values, mask = self.state.push_read(frame.values, frame.mask, self.lag)
        return {"out": PartialFrame(values, mask, frame.events)}
