"""Whether a gaze block can look at a point, and what its look_at command waits for.

`reach(block, target)`: from the eyes at rest, the yaw and pitch (rad) that face `target` and the
interval each axis can turn through (the gaze DoFs' ranges times their effect on the gaze, summed
per axis, about the rest look direction). Within both (to `TOLERANCE`): reachable; otherwise the
gaze stops at the nearest reachable direction, and `clamped_to` is the point it then faces at the
target's distance. A point within `TOO_CLOSE` of the eyes cannot be looked at. The estimate ignores
how the eyes move as the head turns (a few centimetres), which the block's own loop corrects.

`GazeWatch`: a look_at in progress (one at a time): done when the block reports the gaze on target,
or when the gaze has stopped moving short of it (held at a limit) for `STILL_TICKS` ticks in a row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

TOLERANCE = math.radians(1.0)
TOO_CLOSE = 0.05  # m from the eyes
STILL = 1e-5  # rad per tick: the gaze DoFs no longer move
STILL_TICKS = 10


def yaw_pitch(d: np.ndarray) -> tuple[float, float]:
    """Yaw (left +, about z) and pitch (down +, about y) of a direction in the base frame (rad)."""
    return math.atan2(d[1], d[0]), math.atan2(-d[2], math.hypot(d[0], d[1]))


def _direction(yaw: float, pitch: float) -> np.ndarray:
    """Unit vector of a gaze direction (yaw left +, pitch down +) in the base frame."""
    return np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), -math.sin(pitch)])


def _nearest(angle: float, lo: float, hi: float, wraps: bool) -> float:
    """The angle within [lo, hi] nearest to `angle` (a yaw also as angle +- 2 pi: turning a full turn
    the other way faces the same direction)."""
    options = [angle, angle - 2 * math.pi, angle + 2 * math.pi] if wraps else [angle]
    clamped = [min(max(a, lo), hi) for a in options]
    return min(zip(clamped, options), key=lambda c: abs(c[0] - c[1]))[0]


def reach(block: Any, target: Any) -> dict[str, Any]:
    """See the module doc: {reachable, reason, clamped_to, yaw, pitch, yaw_range, pitch_range} (rad)."""
    emb = block.emb
    pose = block.chain.fk(block.chain.q_from_channels(emb.rest.copy()))
    eye = pose[:3, :3] @ block.eye_offset + pose[:3, 3]
    base = yaw_pitch(pose[:3, 0])
    to = np.asarray(target, dtype=float) - eye
    dist = float(np.linalg.norm(to))
    if dist < TOO_CLOSE:
        return {
            "reachable": False,
            "reason": f"the point is within {TOO_CLOSE:g} m of the eyes",
            "clamped_to": None,
        }
    want = yaw_pitch(to / dist)
    spans = []
    for axis in (0, 1):
        sel = block.axis == axis
        ends = np.stack([block.gain[sel] * block.lo[sel], block.gain[sel] * block.hi[sel]])
        spans.append((base[axis] + float(ends.min(axis=0).sum()), base[axis] + float(ends.max(axis=0).sum())))
    got = [_nearest(w, lo, hi, wraps=axis == 0) for axis, (w, (lo, hi)) in enumerate(zip(want, spans))]
    off = [abs(math.remainder(want[0] - got[0], 2 * math.pi)), abs(want[1] - got[1])]
    out_of = [name for name, d in zip(("yaw", "pitch"), off) if d > TOLERANCE]
    result = {
        "reachable": not out_of,
        "reason": None if not out_of else f"beyond the gaze's {' and '.join(out_of)} range",
        "clamped_to": None if not out_of else [round(float(v), 4) for v in eye + dist * _direction(*got)],
        "yaw": round(want[0], 4),
        "pitch": round(want[1], 4),
        "yaw_range": [round(v, 4) for v in spans[0]],
        "pitch_range": [round(v, 4) for v in spans[1]],
    }
    return result


@dataclass
class GazeWatch:
    """A look_at command the block reports the end of (see the module doc). The ticks the gaze has stood
    still since it began are the block's state (`Gaze.State.still`: the compiled core counts them too)."""

    command_id: str
