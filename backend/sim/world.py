"""One simulated robot following joint goals: MuJoCo stepped at its own rate between Animation Frames.

`SimWorld.follow(goals, seconds)` holds the goals for `seconds` (as a servo bus does between frames: a
zero-order hold) and steps the physics; after the steps, contacts are read between links that MuJoCo
does not filter (parent and child, and links welded by fixed joints, never collide), and with the floor
or table plane — once per followed frame (every 10 ms at 100 Hz), so a touch shorter than a frame can
pass unseen. What the motors do is read after the last step: positions, actuator
forces, and the effort as a fraction of each joint's limit (the servo drivers' unit).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.drivers.readings import SATURATED_EFFORT
from backend.sim.availability import mujoco_module
from backend.sim.model import SimModel

mujoco = mujoco_module()  # the [sim] extra, typed as Any (no stubs)

#: A contact counts from this depth (m): shallower touches are the soft contact model's own give.
MIN_DEPTH = 2e-4
#: The longest stretch one `follow` simulates (s): a sink that fell further behind skips the rest.
MAX_CATCH_UP = 0.25


#: (goals, positions (rad or m), efforts (fraction of the limit), torques (N·m or N)), per joint.
Snapshot = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Contact:
    """Two links in contact (sorted names; "floor" or "table" for the planes), the deepest penetration
    seen (m) and where (world frame, m)."""

    links: tuple[str, str]
    depth: float
    position: tuple[float, float, float]


class SimWorld:
    """MuJoCo data for one `SimModel`, driven by joint goals (rad or m, the model's joint order)."""

    def __init__(self, sim: SimModel):
        self.sim = sim
        self.model = sim.model
        self.data = mujoco.MjData(self.model)
        m = self.model
        names = list(sim.body_links)
        self._geom_name = [
            (m.geom(g).name or "world") if m.geom_bodyid[g] == 0 else names[m.geom_bodyid[g]]
            for g in range(m.ngeom)
        ]
        self._low = np.array([m.jnt_range[m.joint(n).id][0] for n in sim.joints])
        self._high = np.array([m.jnt_range[m.joint(n).id][1] for n in sim.joints])
        limited = np.array([bool(m.jnt_limited[m.joint(n).id]) for n in sim.joints], dtype=bool)
        self._low[~limited], self._high[~limited] = -np.inf, np.inf
        self.goals = np.zeros(len(sim.joints))
        self.steps = 0

    @property
    def joint_range(self) -> tuple[np.ndarray, np.ndarray]:
        """Each joint's (lower, upper) limits (rad or m; infinite where unbounded)."""
        return self._low, self._high

    @property
    def time(self) -> float:
        return float(self.data.time)

    def reset(self, joints: np.ndarray) -> None:
        """Stand still at `joints` (clipped to the joints' ranges), holding them."""
        mujoco.mj_resetData(self.model, self.data)
        q = np.clip(np.asarray(joints, dtype=float), self._low, self._high)
        self.data.qpos[self.sim.qpos_adr] = q
        self.data.ctrl[:] = q
        self.goals = q.copy()
        mujoco.mj_forward(self.model, self.data)

    def place_base(
        self, position: tuple[float, float, float], quat: tuple[float, float, float, float]
    ) -> None:
        """Move the base (a robot with spatial DoFs): position (m) and orientation (w, x, y, z)."""
        if self.sim.base_mocap >= 0:
            self.data.mocap_pos[self.sim.base_mocap] = position
            self.data.mocap_quat[self.sim.base_mocap] = quat

    def follow(self, goals: np.ndarray, seconds: float) -> list[Contact]:
        """Hold `goals` for `seconds` (at most MAX_CATCH_UP) and step; the contacts at the end."""
        self.goals = np.asarray(goals, dtype=float)
        self.data.ctrl[:] = self.goals
        n = max(1, round(min(seconds, MAX_CATCH_UP) / self.model.opt.timestep))
        # One call for all the steps: MuJoCo lets go of the interpreter lock for each call, and in a
        # served process (clock, API) every hand-back costs a wait: beside one busy Python thread, ten
        # single steps measured 1.1 ms of CPU per 10 ms frame, one ten-step call 0.19 ms.
        mujoco.mj_step(self.model, self.data, nstep=n)
        self.steps += n
        seen: dict[tuple[str, str], Contact] = {}
        if self.data.ncon:
            self._scan(seen)
        return list(seen.values())

    def _scan(self, seen: dict[tuple[str, str], Contact]) -> None:
        con = self.data.contact
        deep = np.flatnonzero(-con.dist >= MIN_DEPTH)
        for k in deep:
            a, b = self._geom_name[con.geom1[k]], self._geom_name[con.geom2[k]]
            pair = (a, b) if a <= b else (b, a)
            depth = float(-con.dist[k])
            if pair not in seen or seen[pair].depth < depth:
                p = con.pos[k]
                seen[pair] = Contact(pair, depth, (float(p[0]), float(p[1]), float(p[2])))

    # --- what the motors do -----------------------------------------------------------------------
    def positions(self) -> np.ndarray:
        return self.data.qpos[self.sim.qpos_adr].copy()

    def velocities(self) -> np.ndarray:
        return self.data.qvel[self.sim.dof_adr].copy()

    def torques(self) -> np.ndarray:
        """Each motor's force (N·m, or N for a slide joint), within its effort limit."""
        return self.data.actuator_force.copy()

    def efforts(self) -> np.ndarray:
        """Each motor's force as a fraction of its limit (-1..1), as servos report their load."""
        return self.data.actuator_force / self.sim.effort

    def snapshot(self) -> Snapshot:
        """What the motors do now, kept as arrays (copies): cheap to take every frame, turned into
        per-joint readings only when asked (`readings`)."""
        return self.goals.copy(), self.positions(), self.efforts(), self.torques()

    def readings(self, snapshot: Snapshot | None = None) -> dict[str, dict[str, Any]]:
        """Per joint {commanded, measured, error, effort, saturated, torque} (api_types.JointReading), of
        `snapshot` (default: now)."""
        goals, q, effort, torque = snapshot if snapshot is not None else self.snapshot()
        out: dict[str, dict[str, Any]] = {}
        rows = zip(self.sim.joints, goals.tolist(), q.tolist(), effort.tolist(), torque.tolist())
        for name, goal, measured, e, tau in rows:
            out[name] = {
                "commanded": goal,
                "measured": measured,
                "error": goal - measured,
                "effort": e,
                "saturated": abs(e) >= SATURATED_EFFORT,
                "torque": tau,
            }
        return out
