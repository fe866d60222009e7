"""The robot's joint frames at rest, read from its URDF: each joint's axis in its own frame and in the
robot's base frame at the URDF's zero configuration, which the importers map source rotations onto.

`dof_axis` gives a DoF's default axis in the robot's frame at rest (+X forward, +Z up). These are
re-exported by `backend.importers.mapping`.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.importers.channels import ClipImportError
from backend.importers.rotations import (
    IDENTITY,
    RotationError,
    quat_axis_angle,
    quat_mul,
    quat_to_matrix,
    unit,
)

_FRAMES_CACHE: dict[str, dict[str, dict[str, Any]]] = {}
_SPATIAL_AXES = {
    "x": (1, 0, 0),
    "y": (0, 1, 0),
    "z": (0, 0, 1),
    "roll": (1, 0, 0),
    "pitch": (0, 1, 0),
    "yaw": (0, 0, 1),
}


def _floats(text: str | None, default: str, n: int = 3) -> list[float]:
    try:
        vals = [float(x) for x in (text if text is not None else default).split()]
    except ValueError:
        vals = [float(x) for x in default.split()]
    return (
        vals
        if len(vals) == n and all(math.isfinite(v) for v in vals)
        else [float(x) for x in default.split()]
    )


def _rpy_quat(r: float, p: float, y: float) -> np.ndarray:
    qz = quat_axis_angle([0, 0, 1], y)
    qy = quat_axis_angle([0, 1, 0], p)
    qx = quat_axis_angle([1, 0, 0], r)
    return quat_mul(quat_mul(qz, qy), qx)


def robot_joint_frames(urdf_path: str | Path) -> dict[str, dict[str, Any]]:
    """Joint name -> {"axis": local unit axis, "world_axis": the axis in the robot's base frame in
    the URDF's zero configuration, "world": that frame's rotation (quaternion), "child", "parent"}."""
    key = str(urdf_path)
    if key not in _FRAMES_CACHE:
        try:
            root = ET.parse(key).getroot()
        except (OSError, ET.ParseError) as exc:
            raise ClipImportError(f"cannot read joint axes from '{urdf_path}': {exc}") from exc
        raw: dict[str, dict[str, Any]] = {}
        for j in root.iter("joint"):
            el = j.find("axis")
            try:
                axis = unit(_floats(el.get("xyz") if el is not None else None, "1 0 0"))
            except RotationError:
                axis = np.array([1.0, 0.0, 0.0])
            o = j.find("origin")
            rpy = _floats(o.get("rpy") if o is not None else None, "0 0 0")
            parent = j.find("parent")
            child = j.find("child")
            raw[j.get("name", "")] = {
                "axis": axis,
                "origin": _rpy_quat(*rpy),
                "parent": parent.get("link", "") if parent is not None else "",
                "child": child.get("link", "") if child is not None else "",
            }
        by_child = {v["child"]: k for k, v in raw.items()}
        frames: dict[str, dict[str, Any]] = {}

        def world(name: str, depth: int = 0) -> np.ndarray:
            if name in frames:
                return frames[name]["world"]
            j = raw[name]
            up = by_child.get(j["parent"])
            base = world(up, depth + 1) if up is not None and depth < 256 else IDENTITY
            q = quat_mul(base, j["origin"])
            m = _qmat(q)
            frames[name] = {
                "axis": j["axis"],
                "world": q,
                "world_axis": unit(m @ j["axis"]),
                "child": j["child"],
                "parent": up,
            }
            return q

        for name in raw:
            world(name)
        _FRAMES_CACHE[key] = frames
    return _FRAMES_CACHE[key]


def _qmat(q: np.ndarray) -> np.ndarray:

    return quat_to_matrix(q)


def urdf_joint_axes(urdf_path: str | Path) -> dict[str, np.ndarray]:
    """Joint name -> unit axis (the URDF `<axis xyz>`, default 1 0 0) in the joint's own frame."""
    return {k: v["axis"] for k, v in robot_joint_frames(urdf_path).items()}


def dof_joint(emb: Embodiment, dof_name: str) -> str | None:
    """The URDF joint a DoF turns: its own, or for a symbolic DoF the one it drives most."""
    d = emb.dof(dof_name)
    if d.drives:
        return max(d.drives.items(), key=lambda kv: abs(kv[1]))[0]
    return d.joint


def dof_axis(emb: Embodiment, dof_name: str) -> np.ndarray | None:
    """The default axis of a DoF in the robot's frame at rest (the URDF's zero configuration): its
    joint's axis (the most-driven joint's for a symbolic DoF), the base axis for a spatial DoF;
    None if unknown."""
    d = emb.dof(dof_name)
    if d.axis in _SPATIAL_AXES:
        return np.array(_SPATIAL_AXES[d.axis], dtype=float)
    joint = dof_joint(emb, dof_name)
    if joint is None or emb.urdf_path is None:
        return None
    f = robot_joint_frames(emb.urdf_path).get(joint)
    return None if f is None else f["world_axis"]
