"""Where the engine starts when the robot's joints are measured rather than assumed at rest.

A robot with servos that report their position (backend.hardware) stands wherever it was left. The
engine must start its output there, or its first frame would jump to the rest pose: `channels_at`
turns the measured joint values into the channel vector that composes to them (each joint's own
channel takes the difference; the symbolic DoFs stay at rest), and `Engine.start_from` seeds the
safety net with both and blends to the program within every limit.
"""

from __future__ import annotations

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.joint_net import JointLimits

#: The shortest blend from the measured pose to the program at start (s): slower than a swap's, as the
#: robot may stand far from the program's first pose and people are often near it when it powers up.
START_SECONDS = 1.5


def channels_at(emb: Embodiment, joints: JointLimits, measured: np.ndarray) -> np.ndarray:
    """The channels (C,) whose joints are `measured` (over `emb.joint_names`, rad or m; NaN: not
    measured, left at rest) for every joint with an own channel; the others keep the rest pose, and
    the net's joint stage starts them where they were measured (`SafetyNet.reset(..., joints)`)."""
    measured = np.asarray(measured, dtype=float)
    if measured.shape != (len(joints.names),):
        raise ValueError(f"expected {len(joints.names)} joint values, got shape {measured.shape}")
    position = emb.rest.astype(float).copy()
    at_rest = joints.compose(position)
    known = np.isfinite(measured) & (joints.own >= 0)
    position[joints.own[known]] += measured[known] - at_rest[known]
    return position


def outside_range(joints: JointLimits, measured: np.ndarray, tolerance: float) -> list[tuple[str, float]]:
    """The joints measured beyond their URDF range by more than `tolerance` (rad or m): (name, value)."""
    measured = np.asarray(measured, dtype=float)
    with np.errstate(invalid="ignore"):
        beyond = (measured < joints.lower - tolerance) | (measured > joints.upper + tolerance)
    return [(joints.names[j], float(measured[j])) for j in np.flatnonzero(beyond)]
