"""What the robot is doing, observed rather than commanded: where the gaze really points, what the
drivers measure at the motors, and the last frame in a few numbers (the get_frame tool).

`gaze_now(session, frame)`: the point the robot looks at now, from its delivered pose (forward
kinematics of the gaze block's chain at the frame's channels, from the eyes along the gaze direction, at
the target's distance, else 1 m). `measured(session)`: per DoF {commanded, measured, error, effort,
saturated} from every driver that reads its motors (a sink with `measured()`), None when none does.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.control.session_view import CommandSession
from backend.control.targets import blocks_of
from backend.engine.frames import AnimationFrame

DEFAULT_DISTANCE = 1.0  # m: where the gaze point is drawn without a target


def gaze_now(session: CommandSession, frame: AnimationFrame | None, target: Any) -> dict[str, Any] | None:
    """{looking_at: [x, y, z] (m, base frame), eye: [x, y, z], direction: unit vector} or None (no gaze
    block, or no frame yet). Call on the clock thread (it reads the block's chain)."""
    blocks: list[Any] = blocks_of(session, ("gaze",))
    if not blocks or frame is None:
        return None
    block = blocks[0]
    pose = block.chain.fk(block.chain.q_from_channels(frame.position))
    eye = pose[:3, :3] @ block.eye_offset + pose[:3, 3]
    look = pose[:3, 0] / max(float(np.linalg.norm(pose[:3, 0])), 1e-12)
    distance = DEFAULT_DISTANCE
    if target is not None and len(target) == 3:
        distance = max(float(np.linalg.norm(np.asarray(target, dtype=float) - eye)), 0.05)
    return {
        "looking_at": [round(float(v), 4) for v in eye + distance * look],
        "eye": [round(float(v), 4) for v in eye],
        "direction": [round(float(v), 4) for v in look],
    }


def measured(session: CommandSession) -> dict[str, Any] | None:
    """What the drivers that read their motors report, merged (None: no such driver)."""
    out: dict[str, Any] = {}
    found = False
    for sink in session.engine.sinks:
        read: Any = getattr(sink, "measured", None)  # a driver that reads its motors has one
        if callable(read):
            found = True
            readings: Any = read()
            out.update(readings)
    return out if found else None


def frame_summary(session: CommandSession, frame: AnimationFrame | None) -> dict[str, Any]:
    """The last frame compactly: time, continuous DoFs (rad or m, 4 decimals), display DoFs by value,
    the joints the motors get, and the channels the safety net corrected on it."""
    emb = session.embodiment
    if frame is None:
        return {"t": None, "seq": None, "dofs": {}, "joints": {}, "corrected": []}
    full = frame.to_dict(emb, derivatives=False)  # the frame's own JSON form, flattened and rounded here
    dofs: dict[str, Any] = {}
    for name, value in full["dofs"].items():
        if "position" in value:
            dofs[name] = round(value["position"], 4)
        elif "option" in value:
            dofs[name] = value["option"]
        elif "rgb" in value:
            dofs[name] = [round(v, 3) for v in value["rgb"]]
    joints = {name: round(v, 4) for name, v in full.get("joints", {}).items()}
    corrected = (
        [emb.channel_names[i] for i in np.flatnonzero(frame.corrected)] if frame.corrected is not None else []
    )
    return {"t": round(frame.t, 4), "seq": frame.seq, "dofs": dofs, "joints": joints, "corrected": corrected}
