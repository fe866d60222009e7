"""Small, fast forward kinematics of one URDF chain (base link -> tip link), for gaze and IK blocks.

A `Chain` is built once from the URDF (parsed with yourdfpy, no scene graph, no meshes): the fixed
transforms between consecutive moving joints are pre-multiplied, so `fk(q)` is one batched
Rodrigues evaluation plus two 4x4 products per moving joint. Units: m and rad; every pose is the tip
link's frame expressed in the base link's frame.

- `q` is the vector of the chain's *actuated* joints (`Chain.joint_names`, base to tip); a mimic
  joint in the chain follows its leader, which must be in the chain too.
- `jacobian(q, point)` gives the 6xN geometric Jacobian of a point fixed in the tip frame (rows 0-2:
  linear velocity, rows 3-5: angular velocity); `kinematics(q, point, direction)` returns the tip
  pose, the point, a tip-fixed direction and both their Jacobians in one pass (what look-at needs).
- Built from an `Embodiment`, a chain also maps channel vectors to its joints (`q_from_channels`, via
  `Embodiment.joint_positions`, so symbolic DoFs are resolved) and knows which of its joints are
  driven 1:1 by a stationary DoF (`dof_channels`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.urdf_table import UrdfReadError, UrdfTable, table_of_robot, urdf_table

if TYPE_CHECKING:
    from backend.engine.embodiment import Embodiment

_REVOLUTE = ("revolute", "continuous")


class KinematicsError(ValueError):
    """A chain cannot be built (unknown link, no path between the links, unsupported joint)."""


@dataclass(frozen=True)
class _UrdfJoint:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # (4, 4)
    axis: np.ndarray  # (3,) unit
    lower: float
    upper: float
    mimic: tuple[str, float, float] | None  # (leader, multiplier, offset)


@dataclass(frozen=True)
class _UrdfModel:
    joints: dict[str, _UrdfJoint]  # by name
    by_child: dict[str, _UrdfJoint]  # child link -> the joint above it
    links: tuple[str, ...]
    root: str


@lru_cache(maxsize=16)
def _load_model(path: str) -> _UrdfModel:
    try:
        return _model_from_table(urdf_table(path))
    except UrdfReadError as exc:
        raise KinematicsError(str(exc)) from exc


def _model_from_table(table: UrdfTable) -> _UrdfModel:
    joints: dict[str, _UrdfJoint] = {}
    for j in table.joints:
        origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float).reshape(4, 4)
        axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
        norm = float(np.linalg.norm(axis))
        axis = axis / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
        lower, upper = j.lower, j.upper
        if j.type == "continuous" or lower is None or upper is None or not lower < upper:
            lower, upper = -2 * np.pi, 2 * np.pi
        mimic = None
        if j.mimic is not None:
            leader, multiplier, offset = j.mimic
            mimic = (
                leader,
                float(multiplier if multiplier is not None else 1.0),
                float(offset if offset is not None else 0.0),
            )
        joints[j.name] = _UrdfJoint(
            j.name, j.type, j.parent, j.child, origin, axis, float(lower), float(upper), mimic
        )
    by_child = {j.child: j for j in joints.values()}
    links = table.links
    roots = [name for name in links if name not in by_child]
    if not roots:
        raise KinematicsError("URDF has no root link")
    return _UrdfModel(joints, by_child, links, roots[0])


def root_link(source: Any) -> str:
    """The URDF's root link (the robot's base frame) for an Embodiment, a URDF path or a yourdfpy URDF."""
    return _model(source).root


def joint_depths(source: Any) -> dict[str, int]:
    """Number of joints between the root link and each joint (inclusive); deeper joints are more distal."""
    model = _model(source)
    depths: dict[str, int] = {}
    for name, j in model.joints.items():
        d, link = 1, j.parent
        while link in model.by_child:
            d += 1
            link = model.by_child[link].parent
        depths[name] = d
    return depths


def _model(source: Any) -> _UrdfModel:
    if isinstance(source, _UrdfModel):
        return source
    if hasattr(source, "urdf_path") and hasattr(source, "joint_positions"):  # an Embodiment
        if source.urdf_path is None:
            raise KinematicsError(f"robot '{source.name}' has no URDF")
        return _load_model(str(Path(source.urdf_path).resolve()))
    if isinstance(source, (str, Path)):
        return _load_model(str(Path(source).resolve()))
    if hasattr(source, "robot") and hasattr(source.robot, "joints"):  # a yourdfpy.URDF
        return _model_from_table(table_of_robot(source.robot))
    raise TypeError(f"cannot build kinematics from {type(source).__name__}")


def yaw_pitch_roll_quat(yaw: float, pitch: float, roll: float) -> tuple[float, float, float, float]:
    """The unit quaternion (w, x, y, z) of a base orientation given as yaw, pitch, roll (rad; Z-Y-X
    intrinsic, as the spatial DoFs turn the base)."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )


def rotations(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) about unit `axes` (n, 3) by `angles` (n,) rad (Rodrigues, batched)."""
    k = _skew(axes)
    return _rodrigues(k, k @ k, angles)


def _skew(v: np.ndarray) -> np.ndarray:
    k = np.zeros((len(v), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = v[:, 2], -v[:, 1], v[:, 0]
    return k


_I3 = np.eye(3)


def _rodrigues(k: np.ndarray, k2: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """R = I + sin(a) K + (1 - cos(a)) K^2 for precomputed skew matrices K of unit axes."""
    return _I3 + np.sin(angles)[:, None, None] * k + (1.0 - np.cos(angles))[:, None, None] * k2


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (m, 3) arrays (np.cross has a large fixed overhead)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty((len(a), 3))
    out[:, 0] = a1 * b2 - a2 * b1
    out[:, 1] = a2 * b0 - a0 * b2
    out[:, 2] = a0 * b1 - a1 * b0
    return out


class Chain:
    """Forward kinematics of the serial chain from `base_link` (default: the URDF root) to `tip_link`.

    `source` is an `Embodiment` (enables the channel mapping), a URDF path or a `yourdfpy.URDF`.
    """

    def __init__(self, source: Any, base_link: str | None = None, tip_link: str | None = None):
        model = _model(source)
        self.emb = source if hasattr(source, "joint_positions") else None
        base = base_link or model.root
        if tip_link is None:
            raise KinematicsError("a chain needs a tip link")
        for link in (base, tip_link):
            if link not in model.links:
                raise KinematicsError(f"URDF has no link '{link}'")
        path: list[_UrdfJoint] = []
        link = tip_link
        while link != base:
            joint = model.by_child.get(link)
            if joint is None:
                raise KinematicsError(f"link '{tip_link}' is not below link '{base}' in the URDF")
            path.append(joint)
            link = joint.parent
        path.reverse()
        for j in path:
            if j.type not in (*_REVOLUTE, "prismatic", "fixed"):
                raise KinematicsError(f"joint '{j.name}' of type {j.type} is not supported in a chain")
        self.base_link, self.tip_link = base, tip_link
        moving = [j for j in path if j.type != "fixed"]
        actuated = [j for j in moving if j.mimic is None]
        self.joint_names: list[str] = [j.name for j in actuated]
        self.n = len(actuated)
        index = {n: i for i, n in enumerate(self.joint_names)}
        self.lower = np.array([j.lower for j in actuated])
        self.upper = np.array([j.upper for j in actuated])
        # Fixed transforms: pre[m] maps the frame after moving joint m-1 (or the base) to joint m's frame.
        pre, acc = [], np.eye(4)
        for j in path:
            acc = acc @ j.origin
            if j.type != "fixed":
                pre.append(acc)
                acc = np.eye(4)
        self._post = acc  # last moving joint (or base) -> tip
        m = len(moving)
        self._pre = np.array(pre).reshape(m, 4, 4)
        self._axes = np.array([j.axis for j in moving]).reshape(m, 3)
        self._revolute = np.array([j.type in _REVOLUTE for j in moving], dtype=bool)
        self._all_revolute = bool(self._revolute.all())
        self._k = _skew(self._axes)
        self._k2 = self._k @ self._k
        # Moving joint value = mult * q[src] + off (mimic joints follow a leader in the chain).
        src, mult, off = [], [], []
        for j in moving:
            if j.mimic is None:
                src.append(index[j.name])
                mult.append(1.0)
                off.append(0.0)
            else:
                leader, k, o = j.mimic
                if leader not in index:
                    raise KinematicsError(
                        f"mimic joint '{j.name}' follows '{leader}', which is not in the chain"
                    )
                src.append(index[leader])
                mult.append(k)
                off.append(o)
        self._src = np.array(src, dtype=np.intp)
        self._mult, self._off = np.array(mult), np.array(off)
        self._identity_map = bool(m == self.n and np.array_equal(self._src, np.arange(m)))
        self._select = np.zeros((m, self.n))  # d(moving value)/dq
        self._select[np.arange(m), self._src] = self._mult
        self._eye = np.eye(4)
        self._channel_map()

    # --- channel mapping (Embodiment only) --------------------------------------------------------
    def _channel_map(self) -> None:
        emb = self.emb
        self.emb_index = None
        self.dof_channels = np.full(self.n, -1, dtype=np.intp)
        if emb is None:
            return
        names = list(emb.joint_names)
        missing = [n for n in self.joint_names if n not in names]
        if missing:
            raise KinematicsError(f"robot '{emb.name}' does not actuate chain joints {missing}")
        self.emb_index = np.array([names.index(n) for n in self.joint_names], dtype=np.intp)
        for d in emb.dofs:
            if d.joint in self.joint_names and not d.symbolic and d.dimension.value == "stationary":
                self.dof_channels[self.joint_names.index(d.joint)] = d.channels.start

    def channel_map(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(rows, offset, lower, upper), contiguous, such that `q_from_channels(v)` equals
        `clip(rows @ v + offset, lower, upper)` (what compiled kernels evaluate)."""
        if self.emb is None:
            raise KinematicsError("this chain was not built from an Embodiment")
        emb, i = self.emb, self.emb_index
        return (
            np.ascontiguousarray(emb.joint_matrix[i]),
            np.ascontiguousarray(emb.joint_offset[i]),
            np.ascontiguousarray(emb._joint_lower[i]),
            np.ascontiguousarray(emb._joint_upper[i]),
        )

    def q_from_channels(self, values: np.ndarray) -> np.ndarray:
        """The chain's joint positions for a full channel vector (symbolic DoFs resolved, joint limits applied)."""
        if self.emb is None:
            raise KinematicsError("this chain was not built from an Embodiment")
        return self.emb.joint_positions_in_range(values)[self.emb_index]

    # --- kinematics ------------------------------------------------------------------------------
    def _motions(self, q: np.ndarray) -> np.ndarray:
        """Each moving joint's motion transform (m, 4, 4) for chain positions `q`."""
        q = np.asarray(q, dtype=float)
        v = q if self._identity_map else self._mult * q[self._src] + self._off
        m = np.zeros((len(v), 4, 4))
        m[:, 3, 3] = 1.0
        if self._all_revolute:
            m[:, :3, :3] = _rodrigues(self._k, self._k2, v)
        else:
            rev = self._revolute
            m[:, :3, :3] = _rodrigues(self._k, self._k2, np.where(rev, v, 0.0))
            m[:, :3, 3] = self._axes * np.where(rev, 0.0, v)[:, None]
        return m

    def fk(self, q: np.ndarray) -> np.ndarray:
        """The tip link's pose (4x4) in the base link's frame for joint positions `q` (rad or m)."""
        a = np.matmul(self._pre, self._motions(q))
        t = a[0] if len(a) else self._eye
        for k in range(1, len(a)):
            t = t @ a[k]
        return t @ self._post

    def frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint frames before their motion (m, 4, 4: axis origin and orientation) and the tip pose."""
        motion = self._motions(q)
        m = len(motion)
        joint_frames = np.empty((m, 4, 4))
        t = self._eye
        for k in range(m):
            t = t @ self._pre[k]
            joint_frames[k] = t
            t = t @ motion[k]
        return joint_frames, t @ self._post

    def kinematics(
        self, q: np.ndarray, point: np.ndarray | None = None, direction: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One pass: tip pose T, point p (tip frame `point`, default origin), unit direction d (tip frame
        `direction`, default +x), position Jacobian Jp (3xN) of p and direction Jacobian Jd (3xN) of d."""
        joint_frames, tip = self.frames(q)
        p = tip[:3, 3] if point is None else tip[:3, :3] @ point + tip[:3, 3]
        d = tip[:3, 0] if direction is None else tip[:3, :3] @ direction
        z = (joint_frames[:, :3, :3] @ self._axes[:, :, None])[:, :, 0]  # joint axes in the base frame
        jp = _cross(z, p - joint_frames[:, :3, 3])
        jd = _cross(z, d)
        if not self._all_revolute:
            rev = self._revolute
            jp[~rev] = z[~rev]
            jd[~rev] = 0.0
        if self._identity_map:
            return tip, p, d, jp.T, jd.T
        return tip, p, d, jp.T @ self._select, jd.T @ self._select

    def jacobian(self, q: np.ndarray, point: np.ndarray | None = None) -> np.ndarray:
        """Geometric Jacobian (6xN) of a point fixed in the tip frame: linear (rows 0-2), angular (3-5)."""
        joint_frames, tip = self.frames(q)
        p = tip[:3, 3] if point is None else tip[:3, :3] @ np.asarray(point, dtype=float) + tip[:3, 3]
        z = (joint_frames[:, :3, :3] @ self._axes[:, :, None])[:, :, 0]
        jv = _cross(z, p - joint_frames[:, :3, 3])
        jw = z.copy()
        if not self._all_revolute:
            rev = self._revolute
            jv[~rev] = z[~rev]
            jw[~rev] = 0.0
        j = np.concatenate([jv.T, jw.T], axis=0)
        return j if self._identity_map else j @ self._select

    def direction_jacobian(
        self, q: np.ndarray, direction: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """A tip-fixed unit direction (default +x) in the base frame, and its Jacobian (3xN)."""
        dvec = None if direction is None else np.asarray(direction, dtype=float)
        _, _, d, _, jd = self.kinematics(q, None, dvec)
        return d, jd

    def __repr__(self) -> str:
        return f"Chain({self.base_link} -> {self.tip_link}: {', '.join(self.joint_names)})"


@lru_cache(maxsize=64)
def chain_for(emb: Embodiment, base_link: str | None, tip_link: str) -> Chain:
    """A cached `Chain` of an Embodiment (embodiments hash by identity)."""
    return Chain(emb, base_link, tip_link)
