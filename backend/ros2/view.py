"""What robotics tools see of an Animation Frame: the URDF joints the motors get, the base's pose, the
frame's events and a wall-clock stamp, in the plain shapes ROS 2 messages, MCAP recordings and Foxglove
channels are filled from. No ROS import here: MCAP and Foxglove work without ROS installed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.engine.dofs import Dimension
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.kinematics import root_link

#: The fixed frame the base moves in when a robot has spatial DoFs (REP 105's name for it).
ODOM_FRAME = "odom"
#: How far (s) a frame's stamp may drift from when it was made before the epoch is set again.
DRIFT = 0.02


@dataclass(frozen=True, slots=True)
class Stamp:
    """A ROS time: whole seconds and nanoseconds (0..999 999 999) since the Unix epoch."""

    sec: int
    nanosec: int

    @classmethod
    def of(cls, seconds: float) -> Stamp:
        # whole seconds first: seconds * 1e9 of a Unix time would round the nanoseconds to ~256 ns
        sec = math.floor(seconds)
        ns = round((seconds - sec) * 1e9)
        return cls(sec + ns // 1_000_000_000, ns % 1_000_000_000)

    @property
    def nanoseconds(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec


@dataclass(frozen=True, slots=True)
class BasePose:
    """The base in the odom frame: translation (m) and rotation as a unit quaternion (x, y, z, w)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


def quaternion_from_euler(yaw: float, pitch: float, roll: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation yaw about z, then pitch about y, then roll about x (rad; ZYX, as
    REP 103 and the embodiment's spatial axes use them)."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


class FrameView:
    """Reads frames of one robot for robotics tools.

    `joint_names` are the URDF's actuated joints (the order of every joint vector); `base_link` the
    URDF's root link; `has_base` whether the robot has spatial DoFs (then `base(frame)` is its pose in
    `ODOM_FRAME`). `epoch` (Unix s) is the wall time of frame time 0: `stamp(frame)` = epoch + frame.t,
    so stamps follow the engine's fixed-rate clock rather than when a sink got round to the frame.
    """

    def __init__(self, emb: Embodiment, epoch: float = 0.0):
        self.emb = emb
        self.epoch = float(epoch)
        self.joint_names: list[str] = list(emb.joint_names)
        self.base_link = root_link(emb) if emb.urdf_path is not None else "base_link"
        self._spatial = {
            d.axis: d.channels.start for d in emb.dofs_in(Dimension.spatial) if d.axis is not None
        }
        self.has_base = bool(self._spatial)
        self._last: tuple[int, np.ndarray] | None = None

    def stamp(self, frame: AnimationFrame) -> Stamp:
        return Stamp.of(self.epoch + frame.t)

    def follow_wall(self, frame: AnimationFrame, wall: float) -> None:
        """Keep the epoch on the wall clock: `wall` (Unix s) is when the frame was made, never before the
        time it is for, so the smallest `wall - t` seen is the epoch (less the clock's least lateness).
        A clock that falls behind skips ticks and its frame time then lags the wall: when a frame is
        made more than DRIFT later than its stamp says, the epoch moves up to it."""
        offset = wall - frame.t
        if not self.epoch or offset < self.epoch or offset - self.epoch > DRIFT:
            self.epoch = offset

    def joints(self, frame: AnimationFrame) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities) of the actuated joints (rad or m, per s): what the motors get.

        A velocity is the finite difference of the delivered joint values when the previous frame
        (seq - 1) went through this view, as the safety net measures it; otherwise the channels'
        velocities composed (exact for every joint some channel drives with coefficient 1).
        """
        q = np.asarray(frame.joint_values(self.emb), dtype=float)
        last = self._last
        if last is not None and last[0] == frame.seq - 1 and frame.dt > 0:
            qd = (q - last[1]) / frame.dt
        else:
            qd = self.emb.joint_matrix @ frame.velocity
        self._last = (frame.seq, q.copy())
        return q, qd

    def base(self, frame: AnimationFrame) -> BasePose | None:
        """The base's pose in the odom frame, or None for a robot without spatial DoFs."""
        if not self.has_base:
            return None
        p = frame.position
        axis = {a: float(p[c]) for a, c in self._spatial.items()}
        rotation = quaternion_from_euler(axis.get("yaw", 0.0), axis.get("pitch", 0.0), axis.get("roll", 0.0))
        translation = (axis.get("x", 0.0), axis.get("y", 0.0), axis.get("z", 0.0))
        return BasePose(ODOM_FRAME, self.base_link, translation, rotation)

    @staticmethod
    def events(frame: AnimationFrame) -> list[dict[str, Any]]:
        """The frame's events as JSON objects: {"type": "frame_event", "t", "dof", "kind", "payload"}."""
        return [{"type": "frame_event", "t": frame.t, **e.to_dict()} for e in frame.events]
