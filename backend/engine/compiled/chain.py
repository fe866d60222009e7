"""The compiled kernels of a kinematic chain, by the names the IK and gaze blocks import them under:
forward kinematics (`backend.engine.compiled.kinematics`), the IK tick (`backend.engine.compiled.ik`)
and the gaze tick (`backend.engine.compiled.gaze`).
"""

from __future__ import annotations

from backend.engine.compiled.gaze import GAZE_SIG, gaze_constants, gaze_tick, gaze_workspace
from backend.engine.compiled.ik import IK_SIG, ik_constants, ik_tick, ik_workspace
from backend.engine.compiled.kinematics import CHAIN_SIG, _kinematics, chain_args

__all__ = [
    "CHAIN_SIG",
    "GAZE_SIG",
    "IK_SIG",
    "_kinematics",
    "chain_args",
    "gaze_constants",
    "gaze_tick",
    "gaze_workspace",
    "ik_constants",
    "ik_tick",
    "ik_workspace",
]
