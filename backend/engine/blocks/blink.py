"""The blink scheduler: natural eye blinks at random intervals, held back during held expressions and
drawn to gaze shifts."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from backend.engine.blocks.base import BlockParams, DofSelection, Port, PortType, Source, soft_range
from backend.engine.blocks.cells import cell, flag
from backend.engine.blocks.idle import block_rng
from backend.engine.frames import PartialFrame, SteadyFrame
from backend.engine.selectors import channel_mask


class BlinkParams(BlockParams):
    dofs: DofSelection = Field(default=["blink"])
    closed: float | Literal["max", "min"] = Field(
        default="max",
        description="position of a closed eyelid (rad or m), or 'max'/'min' for each DoF's limit",
    )
    close_time: float = Field(default=0.08, ge=0.02, le=1.0, description="time to close (s)")
    hold_time: float = Field(default=0.03, ge=0.0, le=1.0, description="time held closed (s)")
    open_time: float = Field(default=0.18, ge=0.02, le=2.0, description="time to open again (s)")
    min_interval: float = Field(
        default=1.5,
        ge=0.2,
        le=120.0,
        description="shortest time between blinks (s)",
        json_schema_extra=soft_range(0.2, 10, 0.1),
    )
    mean_interval: float = Field(
        default=4.0,
        ge=0.2,
        le=120.0,
        description="average time between blinks (s)",
        json_schema_extra=soft_range(0.2, 20, 0.1),
    )
    max_interval: float = Field(
        default=10.0,
        ge=0.2,
        le=120.0,
        description="longest time between blinks (s)",
        json_schema_extra=soft_range(0.2, 30, 0.1),
    )
    double_blink_probability: float = Field(
        default=0.1, ge=0.0, le=1.0, description="chance a blink is doubled (0..1)"
    )
    double_blink_gap: float = Field(
        default=0.12, ge=0.0, le=2.0, description="pause between the two blinks of a double blink (s)"
    )
    gaze_shift_threshold: float = Field(
        default=0.2,
        ge=0.0,
        le=math.pi,
        description="gaze change that counts as a gaze shift (rad: angle between target directions, or change "
        "of a gaze angle)",
    )
    seed: int = Field(
        default=0, ge=0, le=2**31 - 1, description="random seed (combined with the engine seed and node id)"
    )

    @model_validator(mode="after")
    def _intervals(self) -> BlinkParams:
        if not self.min_interval <= self.mean_interval <= self.max_interval:
            raise ValueError(
                "blink intervals must satisfy min_interval <= mean_interval <= max_interval, got "
                f"min_interval={self.min_interval}, mean_interval={self.mean_interval}, "
                f"max_interval={self.max_interval}"
            )
        return self


class Blink(Source[BlinkParams]):
    """Blinks the eyelids at natural random intervals, never during a held expression, gladly at a gaze shift.

    A blink closes fast, holds briefly and opens more slowly; intervals follow a gamma distribution with
    mean `mean_interval`, clipped to [`min_interval`, `max_interval`], with occasional double blinks.
    While the `hold` input is true blinks are postponed. When the `gaze` target turns by more than
    `gaze_shift_threshold`, the eyes blink with the shift (if the last blink is over `min_interval`/2
    ago), as people do. The run-time command `blink` forces a blink now. Outside blinks the selected
    DoFs sit at rest; `blinking` is true while the lids move.
    """

    type_name = "blink"
    title = "Blink scheduler"
    inputs = {
        "hold": Port(PortType.bool, "while true, no blink starts (a held expression)"),
        "gaze": Port(
            PortType.vec3, "gaze target (m, robot frame); turning it by more than the threshold blinks"
        ),
    }
    outputs = {
        "out": Port(PortType.frame, "the eyelid DoFs"),
        "blinking": Port(PortType.bool, "true during a blink"),
    }

    @dataclass
    class State:
        rng: np.random.Generator
        # The schedule, in an array the compiled core steps in place (backend/engine/core/idle_ops.py's
        # BlinkOp), read and written through the properties below, which name its entries.
        clock: np.ndarray = field(
            default_factory=lambda: np.array([0.0, 0.0, -math.inf, 0.0, 0.0, math.nan, 0.0])
        )
        gaze_ref: np.ndarray | None = None  # the gaze at the last gaze shift
        gaze_seen: tuple | None = None  # (the last gaze value read, the threshold then), to skip repeats

        t = cell("clock", 0, "time since start (s)")
        next_at = cell("clock", 1, "when the next scheduled blink starts (s)")
        last_onset = cell("clock", 2, "when the last regular blink started (s)")
        active = flag("clock", 3, "a blink is under way")
        elapsed = cell("clock", 4, "s into it")
        forced = flag("clock", 6, "the `blink` command asked for a blink")

        @property
        def double_at(self) -> float | None:
            """When the second blink of a double blink starts (s), or None."""
            v = float(self.clock[5])
            return None if math.isnan(v) else v

        @double_at.setter
        def double_at(self, value: float | None) -> None:
            self.clock[5] = math.nan if value is None else value

    def configure(self) -> None:
        p, emb = self.params, self.emb
        self.mask = channel_mask(emb, p.dofs, continuous_only=True)
        if p.closed == "max":
            closed = emb.max
        elif p.closed == "min":
            closed = emb.min
        else:
            closed = np.clip(float(p.closed), emb.min, emb.max)
        self.delta = np.where(self.mask, closed - emb.rest, 0.0)
        # Outside a blink (k = 0) the frame is always the same: made once (frames are read-only).
        self._open_values = np.where(
            self.mask, np.clip(emb.rest + 0.0 * self.delta, emb.min, emb.max), emb.rest
        )
        self._open_frame = SteadyFrame(self._open_values, self.mask, [])

    def reset(self) -> None:
        self.state = self.State(rng=block_rng(self.ctx, self.params.seed, self.node_id))
        self.state.next_at = self._interval()

    # --- scheduling -----------------------------------------------------------------------------
    def _interval(self) -> float:
        """Time to the next blink: min + gamma(shape 2) with the requested mean, clipped to max."""
        p = self.params
        extra = p.mean_interval - p.min_interval
        draw = float(self.state.rng.gamma(2.0, extra / 2.0)) if extra > 0 else 0.0
        return min(p.min_interval + draw, p.max_interval)

    def _start(self, scheduled: bool = True) -> None:
        """Begin a blink now; a regular (not second-of-a-double) blink schedules the next one."""
        s = self.state
        s.active = True
        s.elapsed = 0.0
        if scheduled:
            s.last_onset = s.t
            s.next_at = s.t + self._interval()
            if s.rng.random() < self.params.double_blink_probability:
                p = self.params
                s.double_at = s.t + p.close_time + p.hold_time + p.open_time + p.double_blink_gap
            else:
                s.double_at = None

    def _gaze_shift(self, value: Any) -> bool:
        """Whether the gaze moved by more than the threshold since the last shift: for a target point the
        angle between its directions from the robot (a target moving away is no shift), for a number (or
        other vector) the plain difference."""
        if value is None:
            return False
        s = self.state
        # The same value as last tick, under the same threshold, cannot be a shift: the reference is
        # either that value already (just set) or one it was found too close to a tick ago.
        seen = (tuple(value), self.params.gaze_shift_threshold) if type(value) in (list, tuple) else None
        if seen is not None and seen == s.gaze_seen:
            return False
        s.gaze_seen = seen
        try:
            g = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        except (TypeError, ValueError):
            return False
        if not np.all(np.isfinite(g)):
            return False
        s = self.state
        if s.gaze_ref is None or s.gaze_ref.shape != g.shape:
            s.gaze_ref = g.copy()
            return False
        ref = s.gaze_ref
        n_g, n_ref = float(np.linalg.norm(g)), float(np.linalg.norm(ref))
        if g.size == 3 and n_g > 1e-9 and n_ref > 1e-9:  # a target point: the angle between the directions
            change = math.acos(min(max(float(g @ ref) / (n_g * n_ref), -1.0), 1.0))
        else:  # gaze angle(s)
            change = float(np.linalg.norm(g - ref))
        if change > self.params.gaze_shift_threshold:
            s.gaze_ref = g.copy()
            return True
        return False

    def envelope(self, e: float) -> float:
        """Lid closure (0 open .. 1 closed) at time e into a blink: fast close, hold, slower open."""
        p = self.params
        if e <= 0.0:
            return 0.0
        if e < p.close_time:
            return 0.5 - 0.5 * math.cos(math.pi * e / p.close_time)
        e -= p.close_time
        if e < p.hold_time:
            return 1.0
        e -= p.hold_time
        if e < p.open_time:
            return 0.5 + 0.5 * math.cos(math.pi * e / p.open_time)
        return 0.0

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "blink":
            self.state.forced = True
            return {"blink": True}
        return super().handle(command, args)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        hold = bool(inputs.get("hold") or False)
        shifted = self._gaze_shift(inputs.get("gaze"))
        self.schedule(dt, hold, shifted)
        p, s = self.params, self.state
        k = 0.0
        if s.active:
            s.elapsed += dt
            k = self.envelope(s.elapsed)
            if s.elapsed >= p.close_time + p.hold_time + p.open_time:
                s.active, k = False, 0.0
        emb = self.emb
        if k == 0.0:
            return {"out": self._open_frame, "blinking": s.active}
        values = np.clip(emb.rest + k * self.delta, emb.min, emb.max)
        return {
            "out": PartialFrame(np.where(self.mask, values, emb.rest), self.mask, []),
            "blinking": s.active,
        }

    def schedule(self, dt: float, hold: bool, shifted: bool) -> None:
        """The clock steps by `dt` (s) and a blink starts if one is due: a command's, a double blink's second,
        one at a gaze shift or the scheduled one (none while `hold`). (The compiled core's op calls it when
        a blink starts: the draws are the block's random generator's.)"""
        p, s = self.params, self.state
        s.t += dt
        if not s.active:
            if s.forced:
                self._start()
            elif not hold:
                if s.double_at is not None and s.t >= s.double_at:
                    s.double_at = None
                    self._start(scheduled=False)
                elif (shifted and s.t - s.last_onset > p.min_interval / 2) or s.t >= s.next_at:
                    self._start()
            else:
                s.double_at = None  # a held expression cancels a pending second blink
            s.forced = False
