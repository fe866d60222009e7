"""Overlapping action (the paper's follow-through principle): follow-through, a damped spring that lets
parts settle after the motion stops, and delay, which makes parts trail the motion that leads them.

Both transform the frame on their `in` port and pass through the channels they do not touch, keeping
the frame's events. All per-tick work is vectorised over channels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from backend.engine.blocks.base import (
    BlockParams,
    DofSelection,
    Operator,
    soft_range,
)
from backend.engine.frames import FrameHistory, PartialFrame
from backend.engine.selectors import channel_mask

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
        default=False, description="off by default: overshoot moves the robot beyond the programmed pose"
    )
    frequency: float = Field(
        default=2.0,
        ge=0.1,
        le=20.0,
        description="natural frequency of the spring (Hz)",
        json_schema_extra=soft_range(0.1, 8, 0.05),
    )
    damping: float = Field(
        default=0.3, ge=0.05, le=1.0, description="damping ratio (1 = critical, no overshoot)"
    )
    max_overshoot: float = Field(
        default=0.15,
        ge=0.0,
        le=1.0,
        description="largest distance from the input the output may reach (rad or m)",
    )


class FollowThrough(Operator[FollowThroughParams]):
    """Follow-through: a damped spring on the selected DoFs, so they overshoot and settle after a stop.

    Each selected DoF follows its input through an under-damped spring (natural frequency and damping
    ratio), integrated exactly so it behaves the same at any tick rate. Because overshoot takes the robot
    beyond the programmed pose, the block is disabled by default (then it passes the frame through
    exactly); when enabled the output never strays more than `max_overshoot` from the input and stays
    within the DoF's limits.
    """

    type_name = "follow_through"
    title = "Follow-through"

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
    delay: float = Field(default=0.1, ge=0.0, le=MAX_DELAY, description="delay of the selected DoFs (s)")
    delays: dict[str, float] = Field(
        default_factory=dict, description="DoF name -> its own delay (s, 0..2), overriding `delay`"
    )

    @model_validator(mode="after")
    def _check(self) -> DelayParams:
        for name, d in self.delays.items():
            if not (0.0 <= d <= MAX_DELAY):
                raise ValueError(f"delays['{name}'] = {d} s is outside 0..{MAX_DELAY}")
        return self


class Delay(Operator[DelayParams]):
    """Delays the selected DoFs by a fixed time, for overlapping action (one part moves after another).

    Put it on the layer that drives the ears, say, with 0.15 s: the ears follow the head's motion a
    moment later instead of in lock-step. Each DoF can have its own delay; unselected DoFs and events
    pass through at once. The delay is rounded to whole ticks.
    """

    type_name = "delay"
    title = "Delay / overlap"
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
