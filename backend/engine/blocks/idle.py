"""Procedural idle ("keep-alive") sources: breathing, smooth noise and slow weight shifts.

A robot that stands perfectly still looks switched off. These sources add the small, never-repeating
motions of a living body around the rest pose; put them in an additive layer of a mixer so they ride
on top of whatever else the robot does.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from backend.engine.blocks.base import (
    BlockContext,
    BlockParams,
    DofSelection,
    Source,
    drivable,
    soft_range,
)
from backend.engine.blocks.cells import cell
from backend.engine.compiled import entry_point
from backend.engine.compiled.idle import (
    BREATHE_SIG,
    NOISE_SIG,
    OFFSET_SIG,
    breathe_tick,
    noise_tick,
    offset_tick,
)
from backend.engine.embodiment import DofType, Embodiment
from backend.engine.frames import PartialFrame
from backend.engine.selectors import SelectorError, channel_mask


def block_rng(ctx: BlockContext, seed: int, node_id: str) -> np.random.Generator:
    """A reproducible generator for one block: the engine seed, the block's seed and a stable hash of
    its node id, so two nodes of the same type differ while every run of a program is identical."""
    words = [int(ctx.seed) % 2**32, int(seed) % 2**32, zlib.crc32(node_id.encode("utf-8"))]
    return np.random.default_rng(np.random.SeedSequence(words))


class NormalDraws:
    """A tick's standard normal draws of one shape, drawn from `rng` `batch` ticks at a time: the same
    numbers in the same order as one `standard_normal(shape)` per tick (numpy's generator keeps no
    state between calls but its bit generator's), for one call into numpy per batch, which costs a
    tick woken from a sleep tens of µs however small the draw.

    `cursor[0]` counts the draws of the batch handed out; the compiled core steps it in place and asks
    for `refill` when the batch is used up (backend/engine/core/idle_ops.py's NoiseOp), while `advance` here
    refills when it finds it used up: either way the generator is called for the same batches in the
    same order, as nothing else draws from it."""

    def __init__(self, rng: np.random.Generator, shape: tuple[int, ...], batch: int = 32):
        self.rng = rng
        self.batch = np.empty((batch, *shape))  # refilled in place: its address never changes
        self.cursor = np.full(1, batch, dtype=np.int64)

    @property
    def used(self) -> int:
        """Draws of the batch handed out (the batch is drawn when it is first needed)."""
        return int(self.cursor[0])

    def exhausted(self) -> bool:
        return int(self.cursor[0]) >= len(self.batch)

    def refill(self) -> None:
        """Draw the next batch."""
        self.rng.standard_normal(out=self.batch)
        self.cursor[0] = 0

    def advance(self) -> int:
        """The index of this tick's draws in `batch` (drawing the next batch when this one is used)."""
        if self.exhausted():
            self.refill()
        i = int(self.cursor[0])
        self.cursor[0] = i + 1
        return i

    def next(self) -> np.ndarray:
        """This tick's draws (a view of `batch`, valid until the batch is drawn again)."""
        return self.batch[self.advance()]


def per_dof_vector(
    emb: Embodiment, values: dict[str, float], field_name: str
) -> tuple[np.ndarray, np.ndarray]:
    """Channel vector and mask from a DoF name -> number dict; unknown or non-continuous DoFs are errors."""
    vec = np.zeros(emb.n_channels)
    mask = np.zeros(emb.n_channels, dtype=bool)
    for name, value in values.items():
        if not emb.has_dof(name):
            raise SelectorError(name, f"{field_name}: robot '{emb.name}' has no DoF '{name}'")
        d = emb.dof(name)
        if d.type is not DofType.continuous:
            raise ValueError(f"{field_name}: DoF '{name}' is not continuous")
        vec[d.channels] = float(value)
        mask[d.channels] = True
    return vec, mask


# --------------------------------------------------------------------------------------------------
# Breathing
# --------------------------------------------------------------------------------------------------


class BreatheParams(BlockParams):
    dofs: DofSelection = Field(default=["stationary:*", "!*blink*", "!gaze_*"])
    amplitude: float = drivable(
        Field(default=0.03, ge=0.0, le=1.0, description="peak deviation from the rest pose (rad or m)"),
        "overrides the amplitude parameter (rad or m)",
        clamp="range",
    )
    amplitudes: dict[str, float] = Field(
        default_factory=dict,
        description="per-DoF peak deviation overriding `amplitude` (DoF name -> rad or m; negative inverts)",
    )
    frequency: float = drivable(
        Field(default=0.25, ge=0.0, le=5.0, description="breaths per second (Hz)"),
        "overrides the frequency parameter (Hz)",
        clamp="range",
    )
    phase_spread: float = Field(
        default=0.4,
        ge=-math.pi,
        le=math.pi,
        description="extra phase lag per selected DoF (rad), so the breath travels",
    )
    phases: dict[str, float] = Field(
        default_factory=dict, description="extra phase per DoF (DoF name -> rad), added to the spread"
    )
    inhale_ratio: float = Field(
        default=0.4,
        ge=0.3,
        le=0.7,
        description="fraction of a cycle spent inhaling (rising); < 0.5 inhales faster",
    )


class Breathe(Source[BreatheParams]):
    """Asymmetric breathing around the rest pose on the selected DoFs.

    Each DoF follows a smooth cycle that rises during the inhale (the first `inhale_ratio` of the cycle)
    and falls during the slower exhale; phase warping keeps velocity continuous and the cycle mean at
    rest. A per-DoF phase lag makes the breath travel through the body. The phase is integrated, so a
    live frequency change never jumps; amplitude and frequency can be driven by signals (a connected
    amplitude scales per-DoF overrides in proportion).
    """

    type_name = "breathe"
    title = "Breathing"

    @dataclass
    class State:
        # the phase (cycles, in [0, 1)) in a one-element array: the compiled core steps it in place
        phase: np.ndarray = field(default_factory=lambda: np.zeros(1))

        phi = cell("phase", 0, "The phase (cycles, in [0, 1)).")

    def configure(self) -> None:
        p = self.params
        emb = self.emb
        self.mask = channel_mask(emb, p.dofs, continuous_only=True)
        amp_vec, self.amp_override = per_dof_vector(emb, p.amplitudes, "amplitudes")
        self.amp_override &= self.mask
        self.amp_values = np.where(self.amp_override, amp_vec, 0.0)
        phase_vec, _ = per_dof_vector(emb, p.phases, "phases")
        index = np.cumsum(self.mask) - 1
        phase = np.where(self.mask, index * p.phase_spread + phase_vec, 0.0)
        self.offset_cycles = -phase / (2 * math.pi)  # a positive phase lags behind
        self._kernel = entry_point(breathe_tick, BREATHE_SIG) if self.ctx.compiled else None

    def wave(self, u: np.ndarray) -> np.ndarray:
        """The breath shape on cycle fraction u in [0, 1): -1 at u=0, +1 at the end of the inhale."""
        r = self.params.inhale_ratio
        v = np.where(u < r, 0.5 * u / r, 0.5 + 0.5 * (u - r) / (1.0 - r))
        return -np.cos(2 * math.pi * v)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        p, d, s = self.params, self.driven(inputs), self.state
        scale = d.amplitude / p.amplitude if p.amplitude > 0 else 1.0
        emb = self.emb
        if self._kernel is not None and self.ctx.compiled:  # the compiled twin of the lines below
            out = np.empty(emb.n_channels)
            self._kernel(
                s.phi,
                self.offset_cycles,
                self.amp_override,
                self.amp_values,
                float(scale),
                float(d.amplitude),
                float(p.inhale_ratio),
                emb.rest,
                emb.min,
                emb.max,
                self.mask,
                out,
            )
            s.phi = (s.phi + d.frequency * dt) % 1.0
            return {"out": PartialFrame(out, self.mask, [])}
        amps = np.where(self.amp_override, self.amp_values * scale, d.amplitude)
        u = np.mod(s.phi + self.offset_cycles, 1.0)
        emb = self.emb
        values = np.clip(emb.rest + amps * self.wave(u), emb.min, emb.max)
        s.phi = (s.phi + d.frequency * dt) % 1.0
        return {"out": PartialFrame(np.where(self.mask, values, emb.rest), self.mask, [])}


# --------------------------------------------------------------------------------------------------
# Smooth noise
# --------------------------------------------------------------------------------------------------


class NoiseParams(BlockParams):
    dofs: DofSelection = Field(default=["stationary:*", "!*blink*", "!gaze_*"])
    amplitude: float = drivable(
        Field(default=0.02, ge=0.0, le=1.0, description="standard deviation around the rest pose (rad or m)"),
        "overrides the amplitude parameter (rad or m)",
        clamp="range",
    )
    tau: float = Field(
        default=1.5,
        ge=0.05,
        le=60.0,
        description="correlation time of the wander (s)",
        json_schema_extra=soft_range(0.05, 10, 0.05),
    )
    smoothing: float = Field(
        default=0.3,
        ge=0.0,
        le=10.0,
        description="time constant of the second low-pass stage (s); 0 turns it off",
        json_schema_extra=soft_range(0, 2, 0.01),
    )
    seed: int = Field(
        default=0, ge=0, le=2**31 - 1, description="random seed (combined with the engine seed and node id)"
    )


class Noise(Source[NoiseParams]):
    """Smooth mean-reverting random wander (Ornstein-Uhlenbeck) around the rest pose.

    Each selected DoF wanders independently, pulled back to rest with correlation time `tau`; a second
    low-pass stage (`smoothing`) makes the velocity continuous too. Both stages are discretised exactly
    and the output is rescaled so its long-run standard deviation equals `amplitude` at any tick rate.
    Runs are reproducible (seed, engine seed and node id); the amplitude can be driven by a signal.
    """

    type_name = "noise"
    title = "Smooth noise"

    @dataclass
    class State:
        x: np.ndarray  # OU state, unit stationary variance
        y: np.ndarray  # low-passed state
        rng: np.random.Generator
        draws: NormalDraws  # from `rng`, (2, C) per tick

    def configure(self) -> None:
        self.mask = channel_mask(self.emb, self.params.dofs, continuous_only=True)
        self._dt: float | None = None
        self._tau_s: tuple[float, float] | None = None
        self._kernel = entry_point(noise_tick, NOISE_SIG) if self.ctx.compiled else None

    def reset(self) -> None:
        n = self.emb.n_channels
        rng = block_rng(self.ctx, self.params.seed, self.node_id)
        self.state = self.State(x=np.zeros(n), y=np.zeros(n), rng=rng, draws=NormalDraws(rng, (2, n)))

    def _transition(self, dt: float) -> None:
        """Exact discretisation of the linear SDE (x, y) over dt: x_{n+1} = a x + L11 e1,
        y_{n+1} = c x + b y + L21 e1 + L22 e2 (noise covariance from the stationary covariance)."""
        tau, s = self.params.tau, self.params.smoothing
        if self._dt == dt and self._tau_s == (tau, s):
            return
        a = math.exp(-dt / tau)
        if s <= 0.0:
            b, c, var_y, cov = 0.0, 0.0, 1.0, 1.0
        else:
            b = math.exp(-dt / s)
            c = (dt / s) * b if abs(tau - s) < 1e-9 else tau * (a - b) / (tau - s)
            var_y = cov = tau / (tau + s)
        # Q = Sigma - Phi Sigma Phi^T with Sigma = [[1, cov], [cov, var_y]], Phi = [[a, 0], [c, b]]
        q11 = 1.0 - a * a
        q21 = cov - (a * c + a * b * cov)
        q22 = var_y - (c * c + 2 * c * b * cov + b * b * var_y)
        l11 = math.sqrt(max(q11, 0.0))
        l21 = q21 / l11 if l11 > 1e-15 else 0.0
        l22 = math.sqrt(max(q22 - l21 * l21, 0.0))
        self._coef = (a, b, c, l11, l21, l22, 1.0 / math.sqrt(var_y))
        self._coef_array = np.array(self._coef[:6])
        self._dt, self._tau_s = dt, (tau, s)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        amp = self.driven(inputs).amplitude
        emb, st = self.emb, self.state
        if self._kernel is not None and self.ctx.compiled:
            return self._tick_compiled(self._kernel, dt, amp)
        if dt > 0:
            self._transition(dt)
            a, b, c, l11, l21, l22, _ = self._coef
            e = st.draws.next()
            x_new = a * st.x + l11 * e[0]
            if self.params.smoothing > 0.0:
                st.y = c * st.x + b * st.y + l21 * e[0] + l22 * e[1]
            else:
                st.y = x_new
            st.x = x_new
        tau, s = self.params.tau, self.params.smoothing
        norm = math.sqrt((tau + s) / tau)  # the low-pass stage shrinks the variance by tau / (tau + s)
        values = np.clip(emb.rest + amp * norm * st.y, emb.min, emb.max)
        return {"out": PartialFrame(np.where(self.mask, values, emb.rest), self.mask, [])}

    def _tick_compiled(self, kernel: Callable[..., None], dt: float, amp: float) -> dict[str, Any]:
        """The compiled twin of `tick` (same random draws, same arithmetic)."""
        emb, st, p = self.emb, self.state, self.params
        step = dt > 0
        if step:
            self._transition(dt)
            e = st.draws.next()
        else:
            e = np.zeros((2, emb.n_channels))
        if st.y is st.x:  # without smoothing the reference leaves y and x one array; keep them apart
            st.y = st.y.copy()
        norm = math.sqrt((p.tau + p.smoothing) / p.tau)
        out = np.empty(emb.n_channels)
        coef = self._coef_array if step else np.zeros(6)  # without a step the coefficients are not read
        kernel(
            st.x,
            st.y,
            e,
            coef,
            step,
            p.smoothing > 0.0,
            float(amp * norm),
            emb.rest,
            emb.min,
            emb.max,
            self.mask,
            out,
        )
        return {"out": PartialFrame(out, self.mask, [])}


# --------------------------------------------------------------------------------------------------
# Weight shift
# --------------------------------------------------------------------------------------------------


class WeightShiftParams(BlockParams):
    dofs: DofSelection = Field(default=["*roll*", "*body*", "*torso*"])
    amplitude: float = Field(
        default=0.08, ge=0.0, le=1.0, description="largest offset from the rest pose (rad or m)"
    )
    min_interval: float = Field(
        default=4.0,
        ge=0.5,
        le=120.0,
        description="shortest time between shifts (s)",
        json_schema_extra=soft_range(0.5, 30, 0.1),
    )
    max_interval: float = Field(
        default=12.0,
        ge=0.5,
        le=120.0,
        description="longest time between shifts (s)",
        json_schema_extra=soft_range(0.5, 30, 0.1),
    )
    shift_duration: float = Field(
        default=2.5,
        ge=0.1,
        le=30.0,
        description="time to ease into a new offset (s)",
        json_schema_extra=soft_range(0.1, 10, 0.1),
    )
    seed: int = Field(
        default=0, ge=0, le=2**31 - 1, description="random seed (combined with the engine seed and node id)"
    )

    @model_validator(mode="after")
    def _intervals(self) -> WeightShiftParams:
        if self.min_interval > self.max_interval:
            raise ValueError(
                f"min_interval ({self.min_interval} s) must not exceed max_interval ({self.max_interval} s)"
            )
        return self


class WeightShift(Source[WeightShiftParams]):
    """Slow, asymmetric posture shifts, like a person shifting their weight.

    Every random interval between `min_interval` and `max_interval` a new offset within ±`amplitude` is
    drawn for the selected DoFs, each DoF moving by its own random fraction (never a symmetric sway), and
    the pose eases there over `shift_duration` with a sine in/out. The default selectors (`*roll*`,
    `*body*`, `*torso*`) find the fitting DoFs on any robot. Output: the rest pose plus the offset.
    """

    type_name = "weight_shift"
    title = "Weight shift"

    @dataclass
    class State:
        offset: np.ndarray  # the current offset from rest
        start: np.ndarray  # the offset the running shift started from
        target: np.ndarray  # the offset it goes to
        rng: np.random.Generator
        # (s to the next shift, s into the running shift) in an array: the compiled core steps it in place
        timing: np.ndarray

        until_next = cell("timing", 0, "Seconds to the next shift.")
        elapsed = cell("timing", 1, "Seconds into the running shift.")

    def configure(self) -> None:
        self.mask = channel_mask(self.emb, self.params.dofs, continuous_only=True)
        self._kernel = entry_point(offset_tick, OFFSET_SIG) if self.ctx.compiled else None

    def reset(self) -> None:
        n = self.emb.n_channels
        rng = block_rng(self.ctx, self.params.seed, self.node_id)
        until_next = float(rng.uniform(0.25, 1.0)) * self.params.min_interval
        self.state = self.State(
            offset=np.zeros(n),
            start=np.zeros(n),
            target=np.zeros(n),
            rng=rng,
            timing=np.array([until_next, 0.0]),
        )

    def _new_target(self) -> np.ndarray:
        p, emb, rng = self.params, self.emb, self.state.rng
        magnitude = rng.uniform(0.4, 1.0)  # how big this shift is overall
        fractions = rng.uniform(-1.0, 1.0, emb.n_channels)  # each DoF its own share and direction
        target = p.amplitude * magnitude * fractions
        return np.clip(emb.rest + target, emb.min, emb.max) - emb.rest

    def advance(self, dt: float) -> float:
        """Advance the shift schedule by `dt` (a new shift when one is due); the running shift's eased
        progress k in [0, 1]. (The compiled core's op calls it too.)"""
        p, s = self.params, self.state
        s.until_next -= dt
        if s.until_next <= 0.0:
            s.start = s.offset.copy()
            s.target = self._new_target()
            s.elapsed = 0.0
            s.until_next = float(s.rng.uniform(p.min_interval, p.max_interval))
        s.elapsed += dt
        u = min(s.elapsed / p.shift_duration, 1.0)
        return 0.5 - 0.5 * math.cos(math.pi * u)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s, k = self.state, self.advance(dt)
        emb = self.emb
        if self._kernel is not None and self.ctx.compiled:  # the compiled twin of the lines below
            out = np.empty(emb.n_channels)
            if s.offset is s.start or s.offset is s.target:  # written in place: never one of its inputs
                s.offset = s.offset.copy()
            self._kernel(s.start, s.target, k, s.offset, emb.rest, emb.min, emb.max, self.mask, out)
            return {"out": PartialFrame(out, self.mask, [])}
        s.offset = s.start + k * (s.target - s.start)
        values = np.clip(emb.rest + s.offset, emb.min, emb.max)
        return {"out": PartialFrame(np.where(self.mask, values, emb.rest), self.mask, [])}
