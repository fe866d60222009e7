"""A planner's `trajectory_msgs/JointTrajectory` played into the program's puppet layer, so it drives
the robot through the program's stage 2 and the engine's safety net like any live stream.

`plan_trajectory` checks a trajectory against the robot at once (in the caller's thread), naming the
first joint, point or field that does not fit: every joint must be one a DoF of its own drives (a joint
that only symbolic DoFs move has no single value to set), every position within that DoF's limits,
times strictly increasing. A trajectory is then played on the engine clock (`TrajectoryPlayer.tick`, an
engine tick hook): at each tick the targets are interpolated at the frame's time (cubic Hermite when
every point has velocities, linear otherwise; from the pose at the start to the first point when it
is due later than 0) and handed to the puppet block. After the last point the final pose is held for
`hold` seconds, then the layer is released and fades out. An empty trajectory stops the one playing;
a new one replaces it. Units: rad or m, s.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import count
from typing import Any

import numpy as np

from backend.engine.dofs import Dimension, DofType
from backend.engine.embodiment import Embodiment

log = logging.getLogger(__name__)

DEFAULT_HOLD = 1.0  # s the last point is held before the layer is released
MAX_POINTS = 10_000


class TrajectoryError(ValueError):
    """A trajectory that cannot play; `field` names the part (e.g. 'joint_names[2]', 'points[3].positions')."""

    def __init__(self, message: str, field: str):
        super().__init__(message)
        self.field = field


@dataclass
class Trajectory:
    """A checked trajectory: the DoFs and channels it sets, times (s from its start, increasing),
    positions and optional velocities (points x joints), `start` (engine time, None: at once)."""

    id: int
    joints: list[str]
    dofs: list[str]
    channels: np.ndarray
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None
    start: float | None = None

    @property
    def duration(self) -> float:
        return float(self.times[-1])


_ids = count(1)


def joint_dofs(emb: Embodiment) -> dict[str, str]:
    """Joint name -> the continuous stationary DoF that drives it alone with coefficient 1."""
    return {
        d.joint: d.name
        for d in emb.dofs
        if d.joint and not d.drives and d.dimension is Dimension.stationary and d.type is DofType.continuous
    }


def plan_trajectory(
    emb: Embodiment,
    joint_names: Sequence[str],
    times: Sequence[float],
    positions: Sequence[Sequence[float]],
    velocities: Sequence[Sequence[float]] | None = None,
    start: float | None = None,
) -> Trajectory:
    """A Trajectory, or TrajectoryError naming what does not fit (module doc)."""
    owned = joint_dofs(emb)
    names = list(joint_names)
    if len(set(names)) != len(names):
        raise TrajectoryError("a joint is named twice", "joint_names")
    for i, name in enumerate(names):
        if name not in owned:
            why = (
                "only symbolic DoFs move it"
                if name in emb.joint_names
                else f"robot '{emb.name}' has no actuated joint of that name"
            )
            raise TrajectoryError(f"joint '{name}' cannot be set: {why}", f"joint_names[{i}]")
    if not 0 < len(times) <= MAX_POINTS:
        raise TrajectoryError(f"a trajectory has 1..{MAX_POINTS} points", "points")
    t = np.asarray(times, dtype=float)
    if not np.all(np.isfinite(t)) or t[0] < 0 or np.any(np.diff(t) <= 0):
        raise TrajectoryError(
            "time_from_start must be >= 0 and strictly increasing", "points.time_from_start"
        )
    q = _matrix(positions, len(names), "positions")
    qd = _matrix(velocities, len(names), "velocities") if velocities is not None else None
    dofs = [owned[n] for n in names]
    lo = np.array([emb.dof(d).min for d in dofs])
    hi = np.array([emb.dof(d).max for d in dofs])
    slack = 1e-9 * np.maximum(1.0, hi - lo)
    outside = (q < lo - slack) | (q > hi + slack)
    if outside.any():
        p, j = (int(x) for x in np.argwhere(outside)[0])
        raise TrajectoryError(
            f"joint '{names[j]}' = {q[p, j]:g} at point {p} is outside its DoF '{dofs[j]}' limits "
            f"[{lo[j]:g}, {hi[j]:g}]",
            f"points[{p}].positions[{j}]",
        )
    channels = np.array([emb.dof(d).channels.start for d in dofs], dtype=np.intp)
    return Trajectory(next(_ids), names, dofs, channels, t, np.clip(q, lo, hi), qd, start)


def _matrix(rows: Sequence[Sequence[float]], width: int, field: str) -> np.ndarray:
    for p, row in enumerate(rows):
        if len(row) != width:
            raise TrajectoryError(
                f"point {p} has {len(row)} {field} for {width} joints", f"points[{p}].{field}"
            )
    m = np.array([list(r) for r in rows], dtype=float).reshape(len(rows), width)
    if not np.all(np.isfinite(m)):
        raise TrajectoryError(f"{field} must be finite numbers", f"points.{field}")
    return m


def sample(traj: Trajectory, t: float, start_pose: np.ndarray) -> np.ndarray:
    """The targets at `t` s from the trajectory's start (the final point after its end)."""
    times, q = traj.times, traj.positions
    if t >= times[-1]:
        return q[-1]
    if t < times[0]:  # from the pose the trajectory started at, to its first point
        return start_pose + (q[0] - start_pose) * (t / times[0])
    k = int(np.searchsorted(times, t, side="right")) - 1
    h = times[k + 1] - times[k]
    s = (t - times[k]) / h
    if traj.velocities is None:
        return q[k] + (q[k + 1] - q[k]) * s
    v = traj.velocities
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * q[k]
        + (s3 - 2 * s2 + s) * h * v[k]
        + (-2 * s3 + 3 * s2) * q[k + 1]
        + (s3 - s2) * h * v[k + 1]
    )


class TrajectoryPlayer:
    """Plays trajectories into the puppet block on the engine clock (module doc).

    `engine` is the running Engine (its `apu`, `last_frame`); `notify(event)` is given each event dict
    ({"type": "trajectory", "event": "started" | "completed" | "cancelled" | "failed", "id", ...}) from the
    clock thread, so it must only queue it. `submit` and `stop` may be called from any thread.
    """

    def __init__(self, engine: Any, notify: Callable[[dict[str, Any]], None], hold: float = DEFAULT_HOLD):
        self.engine, self.notify, self.hold = engine, notify, float(hold)
        self._pending: Trajectory | None = None
        self._stop_requested = False
        self._active: Trajectory | None = None
        self._t0 = 0.0
        self._from = np.zeros(0)
        self._completed = False
        self._block_cache: tuple[Any, Any] = (None, None)

    def submit(self, traj: Trajectory) -> None:
        self._pending = traj  # one reference swap: the clock takes it at its next tick

    def stop(self) -> None:
        self._stop_requested = True

    def puppet_block(self) -> Any:
        """The running program's puppet block (None without one); cached per program instance."""
        apu = self.engine.apu
        if self._block_cache[0] is not apu:
            blocks = [s.block for s in apu.steps if s.block.type_name == "puppet"] if apu else []
            self._block_cache = (apu, blocks[0] if blocks else None)
        return self._block_cache[1]

    def tick(self, t: float) -> None:
        """The engine tick hook: start, play, hold or end the trajectory at frame time `t` (s)."""
        if self._stop_requested:
            self._stop_requested = False
            self._pending = None
            self._end("cancelled", reason="an empty trajectory stops the one playing")
        pending, self._pending = self._pending, None
        if pending is not None:
            self._begin(pending, t)
        traj = self._active
        if traj is None:
            return
        block = self.puppet_block()
        if block is None:
            self._end("failed", reason="the running program has no puppet block")
            return
        rel = t - self._t0
        if rel < 0:
            return  # due later (its header stamp)
        if rel >= traj.duration and not self._completed:
            self._completed = True
            self.notify(self._event("completed", traj))
        if rel > traj.duration + self.hold:
            block.handle("release", {})
            self._active = None
            return
        block.handle("set", {"channels": traj.channels, "values": sample(traj, rel, self._from)})

    def _begin(self, traj: Trajectory, t: float) -> None:
        if self._active is not None:
            self._end("cancelled", reason=f"replaced by trajectory {traj.id}")
        frame = self.engine.last_frame
        self._from = frame.position[traj.channels].copy() if frame is not None else traj.positions[0].copy()
        self._t0 = t if traj.start is None or traj.start < t else traj.start
        self._active, self._completed = traj, False
        self.notify(self._event("started", traj, joints=traj.joints, points=len(traj.times)))

    def _end(self, event: str, **details: Any) -> None:
        traj, self._active = self._active, None
        if traj is None:
            return
        block = self.puppet_block()
        if block is not None:
            block.handle("release", {})
        if not self._completed or event != "cancelled":
            self.notify(self._event(event, traj, **details))

    @staticmethod
    def _event(event: str, traj: Trajectory, **details: Any) -> dict[str, Any]:
        duration = traj.duration if math.isfinite(traj.duration) else None
        return {"type": "trajectory", "event": event, "id": traj.id, "duration": duration, **details}
