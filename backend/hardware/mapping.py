"""Joint values <-> a bus's raw units, vectorised over the bus's servos: raw = offset + scale * q
(serial servos: ticks from zero, direction, gear and the model's ticks per turn; PWM servos: the pulse
width line through the two configured points). The goals are clipped to what the servos accept, which
the configuration check (`config.check_against`) has shown covers every joint's whole URDF range."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from backend.engine.embodiment import Embodiment

if TYPE_CHECKING:  # config checks files with this class; only its type is needed here
    from backend.hardware.config import BusConfig


class JointMap:
    """One bus's joints, in the bus's order.

    names: the URDF joints; ids: each joint's servo id (PWM: channel); index: each joint's place in
    `emb.joint_names` (and so in a frame's joint vector); offset, scale: raw = offset + scale * q;
    raw_lo, raw_hi: the goal range the servos accept (raw units).
    """

    def __init__(self, config: BusConfig, emb: Embodiment):
        mapping = config.joint_map()
        names = list(emb.joint_names)
        self.names = list(mapping)
        self.ids = [int(mapping[n][0]) for n in self.names]
        self.index = np.array([names.index(n) for n in self.names], dtype=np.int64)
        self.offset = np.array([mapping[n][1] for n in self.names], dtype=float)
        self.scale = np.array([mapping[n][2] for n in self.names], dtype=float)
        self.raw_lo, self.raw_hi = config.raw_range()
        limits = {j.name: j for j in emb.joints}
        #: The URDF range of each joint (rad or m).
        self.lower = np.array([limits[n].lower for n in self.names], dtype=float)
        self.upper = np.array([limits[n].upper for n in self.names], dtype=float)

    def urdf_span(self) -> tuple[np.ndarray, np.ndarray]:
        """(lowest, highest) raw goal each servo needs to cover its joint's whole URDF range."""
        ends = np.stack([self.offset + self.scale * self.lower, self.offset + self.scale * self.upper])
        return ends.min(axis=0), ends.max(axis=0)

    def to_raw(self, joints: np.ndarray) -> np.ndarray:
        """Goals (raw units) for a whole joint vector (over `emb.joint_names`, rad or m)."""
        raw = self.offset + self.scale * joints[self.index]
        return np.clip(raw, self.raw_lo, self.raw_hi)

    def to_joints(self, raw: np.ndarray) -> np.ndarray:
        """Joint values (rad or m) of raw positions in the bus's order (NaN stays NaN)."""
        return (np.asarray(raw, dtype=float) - self.offset) / self.scale

    def describe(self, k: int) -> str:
        """`head_yaw (id 3)`: the k-th joint for messages."""
        return f"{self.names[k]} (id {self.ids[k]})"
