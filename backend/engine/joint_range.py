"""Warnings for postures and clips whose DoF combination leaves a joint's URDF range.

Each DoF can be within its own limits while the joint they compose to is not (neck_pitch 0.5 plus
gaze_pitch 0.45 puts the neck_pitch joint at 0.77 rad against a limit of 0.5). The engine's safety
net then holds the joint at its limit (and counts the correction); these warnings tell the author at
save time, naming the joint and the amount. The DoFs a posture or clip does not set are at rest.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.engine.blocks.core import pose_vector
from backend.engine.embodiment import Embodiment

#: Clip time step (s) for the range check: fine enough for keyed motion, cheap for long clips.
CLIP_STEP = 0.01
#: Excursions smaller than this (rad or m) are rounding, not a warning.
TOLERANCE = 1e-9


def _describe(joint: str, value: float, unit: str, over: float, lo: float, hi: float, when: str) -> str:
    side = (
        f"{over:.3g} above its upper limit {hi:g}"
        if over > 0
        else f"{-over:.3g} below its lower limit {lo:g}"
    )
    return (
        f"joint '{joint}' reaches {value:.3f} {unit}{when}, {side}: the DoFs that drive it add up past its "
        f"range, so the safety net will hold it at the limit"
    )


def posture_warnings(values: dict[str, Any], emb: Embodiment) -> list[str]:
    """One warning per joint that a (validated) posture's values, the rest elsewhere, put outside its
    range: the pose the posture block plays (`pose_vector`)."""
    x, _ = pose_vector(emb, values)
    return _range_warnings(emb, emb.joint_positions(x)[None, :], None)


def clip_warnings(compiled: Any, emb: Embodiment) -> list[str]:
    """One warning per joint that a compiled clip (`backend.engine.clips.CompiledClip`) puts outside its
    range at some time, at the worst moment."""
    n = max(2, int(np.ceil(compiled.duration / CLIP_STEP)) + 1)
    times = np.linspace(0.0, compiled.duration, n)
    x = np.tile(emb.rest, (n, 1))
    for k, t in enumerate(times):
        compiled.sample(float(t), emb.rest, x[k])
    q = x @ emb.joint_matrix.T + emb.joint_offset
    return _range_warnings(emb, q, times)


def _range_warnings(emb: Embodiment, q: np.ndarray, times: np.ndarray | None) -> list[str]:
    lo, hi = emb.joint_lower, emb.joint_upper
    over = np.where(q > hi + TOLERANCE, q - hi, np.where(q < lo - TOLERANCE, q - lo, 0.0))
    out = []
    for j in np.flatnonzero(np.any(over != 0.0, axis=0)):
        k = int(np.argmax(np.abs(over[:, j])))
        unit = "m" if emb.joints[j].type == "prismatic" else "rad"
        when = "" if times is None else f" at {times[k]:.2f} s"
        out.append(
            _describe(
                emb.joint_names[j], float(q[k, j]), unit, float(over[k, j]), float(lo[j]), float(hi[j]), when
            )
        )
    return out
