"""Every URDF joint's parent -> child link transform for one frame's joint values, as a tf2_msgs/TFMessage
in CDR: what a viewer's URDF layer needs to pose every link without robot_state_publisher.

The joints' poses come from `backend.previz_pose.UrdfPoser.poses` (all joints at once: fixed joints keep
their origin, moving joints turn or slide about their axis, a mimic joint follows its leader). The message
bytes are a template made once per robot, since only the stamp and the seven numbers of each transform
change from frame to frame: a frame writes them into a copy with two numpy fancy-index assignments, no
per-joint Python loop and no message objects (backend/foxglove/cdr_templates.py).

Units: m, unit quaternions (x, y, z, w); the optional base transform (odom -> root link) comes first.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.foxglove.cdr_templates import TfTemplate
from backend.previz_pose import UrdfPoser
from backend.ros2.view import ODOM_FRAME, BasePose, Stamp

_VALUES = TfTemplate.VALUES  # translation x, y, z and rotation x, y, z, w


def _urdf_joints(emb: Embodiment) -> list[Any]:
    """The URDF's joints as yourdfpy parses them (what UrdfPoser takes)."""
    import yourdfpy  # lazy: only robots with a URDF get transforms, and it is slow to import

    urdf = yourdfpy.URDF.load(
        str(emb.urdf_path), build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False
    )
    return list(urdf.robot.joints)


class LinkTransforms:
    """The link transforms of one robot: `frames` are the (parent, child) pairs in message order, one per
    URDF joint (fixed ones too), after odom -> `base_link` when `base_link` is given (a robot with
    spatial DoFs). `message(stamp, q, base)` is the TFMessage for the actuated joint values `q` (rad or
    m, in `emb.joint_names` order) and the base's pose."""

    def __init__(self, emb: Embodiment, base_link: str | None = None):
        if emb.urdf_path is None:
            raise ValueError(f"robot '{emb.name}' has no URDF: it has no link transforms")
        joints = _urdf_joints(emb)
        self.poser = UrdfPoser(joints, [None] * len(joints), list(emb.joint_names))
        self.base_link = base_link
        self.frames: list[tuple[str, str]] = [(j.parent, j.child) for j in joints]
        if base_link is not None:
            self.frames.insert(0, (ODOM_FRAME, base_link))
        self._template = TfTemplate(self.frames)
        self._first = 1 if base_link is not None else 0

    @property
    def links(self) -> set[str]:
        """Every frame the transforms name (the URDF's links, and odom with a base)."""
        return {name for pair in self.frames for name in pair}

    def values(self, q: np.ndarray, base: BasePose | None = None) -> np.ndarray:
        """(n, 7): each transform's translation (m) and rotation (x, y, z, w), in `frames` order."""
        _, wxyz, position = self.poser.poses(np.asarray(q, dtype=float))
        out = np.empty((len(self.frames), _VALUES))
        k = self._first
        out[k:, 0:3] = position
        out[k:, 3:6] = wxyz[:, 1:4]
        out[k:, 6] = wxyz[:, 0]
        if k:
            if base is None:
                raise ValueError("this robot has spatial DoFs: give the base's pose (FrameView.base)")
            out[0, 0:3] = base.translation
            out[0, 3:7] = base.rotation
        return out

    def message(self, stamp: Stamp, q: np.ndarray, base: BasePose | None = None) -> bytes:
        """tf2_msgs/TFMessage (CDR with its encapsulation header): every transform stamped `stamp`."""
        return self._template.message(stamp, self.values(q, base))
