"""Where a robot's moving joints sit: what a DCC rig (the Blender add-on, blender/nutty_blender) needs to
put one bone on each joint and its meshes on the right bones.

For every non-fixed URDF joint, `joint_frames(emb)` gives, with *every joint at zero* (the URDF's own
zero configuration, not the robot's rest pose):

- `origin` (m) and `rotation` (3x3, rows) of the joint frame in the root link's frame (the robot's
  base frame: +X forward, +Z up), i.e. the child link's frame at zero;
- `axis`: the joint axis as a unit vector in the root link's frame (URDF default [1, 0, 0]); a positive
  angle turns the child link right-handedly about it;
- `parent_joint`: the nearest non-fixed joint above it (None: it hangs from the root link);
- `links`: the links that move rigidly with it (its child link and those fixed below it);
- `type`, `limits` ([lower, upper] in rad or m, as the engine clamps joint positions; None when
  unbounded) and `mimic` ({joint, multiplier, offset} for a mimic joint, else None).

`root_links(emb)` lists the links that move with no joint (the base). A robot without a URDF has none.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.kinematics import _model  # the parsed URDF, cached per file

if TYPE_CHECKING:
    from backend.engine.embodiment import Embodiment


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _zero_pose(model: Any) -> dict[str, np.ndarray]:
    """Each link's 4x4 frame in the root link's frame with every joint at zero."""
    frames = {model.root: np.eye(4)}
    pending = list(model.joints.values())
    while pending:  # parents first; a URDF is a tree, so every pass places at least one link
        left = [j for j in pending if j.parent not in frames]
        if len(left) == len(pending):
            break  # links not connected to the root (a malformed URDF): left out
        for j in pending:
            if j.parent in frames:
                frames[j.child] = frames[j.parent] @ j.origin
        pending = left
    return frames


def _moving_joint_above(model: Any, link: str) -> str | None:
    """The nearest non-fixed joint between `link` and the root (None: `link` is rigid with the root)."""
    while link in model.by_child:
        j = model.by_child[link]
        if j.type != "fixed":
            return j.name
        link = j.parent
    return None


def joint_frames(emb: Embodiment) -> dict[str, dict[str, Any]]:
    """Frame, axis, parent joint, rigid links and limits of every non-fixed joint (see the module doc),
    by joint name, parents before children. Empty for a robot without a URDF."""
    if emb.urdf_path is None:
        return {}
    model = _model(emb)
    frames = _zero_pose(model)
    limits = {j.name: (j.lower, j.upper) for j in emb.joints}
    out: dict[str, dict[str, Any]] = {}
    for link in frames:  # insertion order of _zero_pose: parents first
        j = model.by_child.get(link)
        if j is None or j.type == "fixed":
            continue
        frame = frames[link]
        lower, upper = limits.get(j.name, (j.lower, j.upper))
        out[j.name] = {
            "joint": j.name,
            "type": j.type,
            "parent_joint": _moving_joint_above(model, j.parent),
            "origin": [float(x) for x in frame[:3, 3]],
            "rotation": [[float(x) for x in row] for row in frame[:3, :3]],
            "axis": [float(x) for x in frame[:3, :3] @ j.axis],
            "links": [name for name in frames if _moving_joint_above(model, name) == j.name],
            "limits": [_finite(lower), _finite(upper)] if j.type != "continuous" else [None, None],
            "mimic": None
            if j.mimic is None
            else {"joint": j.mimic[0], "multiplier": j.mimic[1], "offset": j.mimic[2]},
        }
    return out


def root_links(emb: Embodiment) -> list[str]:
    """Links that no joint moves (the base and what is fixed to it)."""
    if emb.urdf_path is None:
        return []
    model = _model(emb)
    return [name for name in _zero_pose(model) if _moving_joint_above(model, name) is None]
