"""Animation Frames (AF) and Partial Animation Frames (PAF).

Both are structure-of-arrays over the embodiment's channels (see `Embodiment`): one float64 vector
per quantity, never one object per DoF. Events (speech, sounds, one-shot display changes) ride
along as a short list, since they are discrete and rare. `FrameHistory` keeps the last frames for
operators that look back in time (delays).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.engine.embodiment import DofType, Embodiment


@dataclass(slots=True)
class FrameEvent:
    """A discrete event on an event DoF (or a one-shot on a display DoF).

    `kind` examples: "say" (payload {"text"}), "sound" (payload {"clip"}), "expression".
    """

    dof: str
    kind: str
    payload: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"dof": self.dof, "kind": self.kind, "payload": dict(self.payload)}


@dataclass(slots=True)
class PartialFrame:
    """A PAF: values for the channels whose `mask` is True, plus events. An empty PAF has no effect."""

    values: np.ndarray  # (C,) float64
    mask: np.ndarray  # (C,) bool
    events: list[FrameEvent] = field(default_factory=list)

    @classmethod
    def empty(cls, n_channels: int) -> PartialFrame:
        return cls(np.zeros(n_channels), np.zeros(n_channels, dtype=bool), [])

    @classmethod
    def full(cls, values: np.ndarray, events: list[FrameEvent] | None = None) -> PartialFrame:
        return cls(np.asarray(values, dtype=float), np.ones(len(values), dtype=bool), list(events or []))

    @property
    def is_empty(self) -> bool:
        return not self.events and not bool(self.mask.any())

    def copy(self) -> PartialFrame:
        return PartialFrame(self.values.copy(), self.mask.copy(), list(self.events))

    def apply_to(self, base: np.ndarray) -> np.ndarray:
        """The full vector obtained by writing this PAF over `base` (out-of-place)."""
        return np.where(self.mask, self.values, base)


@dataclass(slots=True)
class AnimationFrame:
    """A complete AF for every DoF of an embodiment.

    Header: embodiment name, time `t` (s since the engine started), `dt` (s), sequence number `seq`.
    `position` holds every channel (rad, m, colour component or enum index); `velocity`,
    `acceleration` and `jerk` are finite differences of the emitted positions (per s, s², s³).
    `stage1` is the pose before the stage-2 post-processors (the paper's *ghost*), if there are any.
    `program` is the program's own frame before the engine's safety net, and `corrected` marks the
    channels the net had to change on this frame (None when it passed everything through).
    `joints` are the actuated URDF joints' positions (rad or m, `Embodiment.joint_names` order) the
    motors get: the channels composed (own DoF plus symbolic DoFs) and limited by the net's joint stage.
    """

    embodiment: str
    t: float
    dt: float
    seq: int
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    events: list[FrameEvent] = field(default_factory=list)
    stage1: np.ndarray | None = None
    corrected: np.ndarray | None = None  # (C,) bool: channels the safety net corrected (None: none)
    program: np.ndarray | None = None  # (C,) the program's frame before the safety net
    joints: np.ndarray | None = None  # (J,) the joints the motors get (None: compose `position`)

    def joint_values(self, embodiment: Embodiment) -> np.ndarray:
        """The joints the motors get (rad or m): the net's `joints`, or the channels composed."""
        return self.joints if self.joints is not None else embodiment.joint_positions(self.position)

    def to_dict(self, embodiment: Embodiment, derivatives: bool = True) -> dict[str, Any]:
        """JSON-friendly form keyed by DoF name: continuous -> float, enum -> option, colour -> [r,g,b]."""
        dofs: dict[str, Any] = {}
        # Python floats of whole vectors at once (what float() of each element gives, without the calls).
        position = self.position.tolist()
        if derivatives:
            velocity, acceleration, jerk = (
                self.velocity.tolist(),
                self.acceleration.tolist(),
                self.jerk.tolist(),
            )
        else:
            velocity = acceleration = jerk = []  # not read without derivatives
        for d in embodiment.dofs:
            sl = d.channels
            if d.type is DofType.continuous:
                c = sl.start
                dofs[d.name] = (
                    {
                        "position": position[c],
                        "velocity": velocity[c],
                        "acceleration": acceleration[c],
                        "jerk": jerk[c],
                    }
                    if derivatives
                    else {"position": position[c]}
                )
            elif d.type is DofType.enum:
                index = round(position[sl.start])
                dofs[d.name] = {"index": index, "option": d.options[index] if d.options else None}
            elif d.type is DofType.colour:
                dofs[d.name] = {"rgb": position[sl]}
        out: dict[str, Any] = {
            "embodiment": self.embodiment,
            "t": self.t,
            "dt": self.dt,
            "seq": self.seq,
            "dofs": dofs,
            "events": [e.to_dict() for e in self.events],
        }
        if embodiment.joint_names:
            out["joints"] = dict(zip(embodiment.joint_names, self.joint_values(embodiment).tolist()))
        return out


@dataclass
class FrameHistory:
    """A ring buffer of the last frames (values and masks), read back per channel a number of ticks ago
    (the state of the delay and asymmetry operators)."""

    values: np.ndarray  # (capacity, channels)
    mask: np.ndarray  # (capacity, channels) bool
    head: int = 0
    primed: bool = False

    @classmethod
    def for_delay(cls, max_seconds: float, rate: float, n_channels: int) -> FrameHistory:
        """Room for delays up to `max_seconds` at `rate` Hz."""
        capacity = math.ceil(max_seconds * rate) + 2
        return cls(np.zeros((capacity, n_channels)), np.zeros((capacity, n_channels), dtype=bool))

    def push_read(
        self, values: np.ndarray, mask: np.ndarray, lag: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Store this tick's frame and read each channel `lag[c]` ticks back (0 = now)."""
        cap = self.values.shape[0]
        if not self.primed:  # start as if the first frame had always been there: no jump at start
            self.values[:] = values
            self.mask[:] = mask
            self.primed = True
        self.values[self.head] = values
        self.mask[self.head] = mask
        rows = (self.head - np.minimum(lag, cap - 1)) % cap
        cols = np.arange(values.shape[0])
        out_v, out_m = self.values[rows, cols], self.mask[rows, cols]
        self.head = (self.head + 1) % cap
        return out_v, out_m
