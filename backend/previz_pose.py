"""Posing a viser URDF robot cheaply: the joint frames' poses computed for all joints at once, and only
the frames that moved sent to viser.

`viser.extras.ViserUrdf.update_cfg` recomputes the whole yourdfpy scene graph and writes every joint
frame through viser's setters (a rotation-matrix conversion and two `allclose` tests each): about
14 ms per robot on a small desk robot, run on the Pre-Viz sink's thread, which holds the interpreter
lock the engine's clock needs. `UrdfPoser` keeps, per joint, the fixed part of its transform (origin
rotation as a quaternion, origin translation, axis) and per frame evaluates

    q = q_origin ⊗ (cos θ/2, axis sin θ/2)     (revolute and continuous joints)
    p = t_origin + R_origin (axis d)            (prismatic joints)

with θ or d the joint's value (a mimic joint follows its leader: multiplier × leader + offset), then
sets `wxyz` / `position` of the frames whose joint moved by more than `EPSILON` since they were last
sent. Units: rad and m (times the robot's `scale`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Joint motion (rad or m) below which a frame is not sent again: far below what a screen shows.
EPSILON = 1e-5

_ROTATING, _SLIDING = ("revolute", "continuous"), ("prismatic",)


def _quat_from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method)."""
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q)


class UrdfPoser:
    """Poses the joint frames of one `ViserUrdf` from configurations in its actuated-joint order.

    `joints` are the yourdfpy joints and `handles` the viser frames, pairwise (as ViserUrdf made them);
    `actuated` the names of the actuated joints (the order of a configuration vector).
    """

    def __init__(self, joints: list[Any], handles: list[Any], actuated: list[str], scale: float = 1.0):
        index = {name: k for k, name in enumerate(actuated)}
        n = len(joints)
        self.handles = list(handles)
        self.scale = float(scale)
        self.q_origin = np.zeros((n, 4))
        self.t_origin = np.zeros((n, 3))
        self.r_origin = np.zeros((n, 3, 3))
        self.axis = np.zeros((n, 3))
        self.rotating = np.zeros(n, dtype=bool)
        self.sliding = np.zeros(n, dtype=bool)
        self.src = np.zeros(n, dtype=np.intp)
        self.mult = np.zeros(n)
        self.off = np.zeros(n)
        for k, j in enumerate(joints):
            origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
            self.r_origin[k] = origin[:3, :3]
            self.q_origin[k] = _quat_from_matrix(origin[:3, :3])
            self.t_origin[k] = origin[:3, 3]
            axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
            self.axis[k] = axis / (np.linalg.norm(axis) or 1.0)
            leader, mult, off = j.name, 1.0, 0.0
            if j.mimic is not None:
                leader = j.mimic.joint
                mult = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
                off = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
            if leader in index and j.type in (*_ROTATING, *_SLIDING):
                self.rotating[k] = j.type in _ROTATING
                self.sliding[k] = j.type in _SLIDING
                self.src[k], self.mult[k], self.off[k] = index[leader], mult, off
        self._last: np.ndarray | None = None  # the joint values last sent, per frame

    def poses(self, cfg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(joint values (n,), wxyz (n, 4), positions (n, 3)) of every joint frame for `cfg`."""
        cfg = np.asarray(cfg, dtype=float)
        moving = self.rotating | self.sliding
        value = (
            np.where(moving, self.mult * cfg[self.src] + self.off, 0.0) if len(cfg) else np.zeros(len(moving))
        )
        half = np.where(self.rotating, 0.5 * value, 0.0)
        c, s = np.cos(half), np.sin(half)
        aw, ax, ay, az = c, self.axis[:, 0] * s, self.axis[:, 1] * s, self.axis[:, 2] * s
        w0, x0, y0, z0 = self.q_origin.T
        wxyz = np.stack(
            [
                w0 * aw - x0 * ax - y0 * ay - z0 * az,
                w0 * ax + x0 * aw + y0 * az - z0 * ay,
                w0 * ay - x0 * az + y0 * aw + z0 * ax,
                w0 * az + x0 * ay - y0 * ax + z0 * aw,
            ],
            axis=1,
        )
        slide = np.where(self.sliding, value, 0.0)[:, None] * self.axis
        position = (self.t_origin + np.einsum("kij,kj->ki", self.r_origin, slide)) * self.scale
        return value, wxyz, position

    def update(self, cfg: np.ndarray) -> int:
        """Send the frames whose joint moved since they were last sent; returns how many were sent."""
        value, wxyz, position = self.poses(cfg)
        last = self._last
        first = last is None
        changed = np.ones(len(value), dtype=bool) if last is None else np.abs(value - last) > EPSILON
        if not changed.any():
            return 0
        self._last = value if last is None else np.where(changed, value, last)
        quats, points = wxyz.tolist(), position.tolist()
        for k in np.flatnonzero(changed).tolist():
            handle = self.handles[k]
            handle.wxyz = quats[k]
            if first or self.sliding[k]:  # a rotating joint's origin never moves
                handle.position = points[k]
        return int(changed.sum())


def poser_for(robot: Any) -> UrdfPoser | None:
    """A cheap poser for a ViserUrdf (its joints and frames, as it made them); None when this viser
    version keeps them elsewhere (its own `update_cfg` is used then)."""
    joints, handles = getattr(robot, "_joint_map_values", None), getattr(robot, "_joint_frames", None)
    if not joints or not handles or len(joints) != len(handles):
        return None
    return UrdfPoser(joints, handles, list(robot.get_actuated_joint_names()), getattr(robot, "_scale", 1.0))


def set_if_changed(handle: Any, name: str, value: Any) -> None:
    """Assign a scene property only when it differs (viser's setters compare arrays with allclose, and
    queue a message when it does differ: both cost far more than this comparison)."""
    current = getattr(handle, name)
    if isinstance(current, np.ndarray):
        if current.shape == (len(value),) and current.tolist() == list(value):
            return
    elif current == value:
        return
    setattr(handle, name, value)
