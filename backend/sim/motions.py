"""The two motions `nutty sim report` compares, from the engine itself run headless (no clock).

For a program, at every tick: the *raw* joints are the program's pose before its stage 2 and the safety
net (the frame's `stage1`, else the program's own frame), composed to joints; the *filtered* joints are
what the motors get (the frame's `joints`). A clip is played from t = 0 by a program's clip player (the
robot's default program unless another is given; a robot without programs gets `clip_stage`), with its document inline as the clip editor sends it,
and run for its duration plus `SETTLE` seconds.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment

#: After a clip ends, how long the report keeps simulating (s): the motors catching up.
SETTLE = 1.0
#: The longest motion a report runs (s).
MAX_SECONDS = 600.0


class MotionError(ValueError):
    """A clip or program the report cannot run; the message says why."""


@dataclass
class Motion:
    """Joint goals per tick (T, J: emb.joint_names order, rad or m) at `rate` Hz."""

    name: str
    kind: str  # "clip" or "program"
    rate: float
    raw: np.ndarray
    filtered: np.ndarray


def read_document(path: Path) -> dict[str, Any]:
    try:
        doc = json.loads(path.read_text())
    except OSError as exc:
        raise MotionError(f"cannot read '{path}': {exc.strerror}") from exc
    except json.JSONDecodeError as exc:
        raise MotionError(f"'{path}' is not JSON: {exc}") from exc
    if not isinstance(doc, dict) or doc.get("format") not in ("nutty-clip/1", "nutty-program/1"):
        raise MotionError(f"'{path}' is neither a clip (nutty-clip/1) nor a program (nutty-program/1)")
    return doc


def find_target(emb: Embodiment, target: str) -> Path:
    """A file path, or the name of one of the robot's clips or programs."""
    path = Path(target)
    if path.is_file():
        return path
    folder = emb.urdf_path.parent if emb.urdf_path is not None else None
    for kind in ("clips", "programs"):
        candidate = folder / kind / f"{target}.json" if folder is not None else None
        if candidate is not None and candidate.is_file():
            return candidate
    raise MotionError(f"no file '{target}', and no clip or program of {emb.name} by that name")


def run_program(
    emb: Embodiment,
    program: dict[str, Any],
    seconds: float,
    rate: float | None = None,
    timeline: list[tuple[float, dict[str, Any]]] | None = None,
) -> tuple[float, np.ndarray, np.ndarray]:
    """(rate, raw joints, filtered joints) of `program` run headless for `seconds`."""
    from backend.session import EngineSession, SessionError  # lazy: the engine's session is heavy

    if not 0 < seconds <= MAX_SECONDS:
        raise MotionError(f"--seconds must be within (0, {MAX_SECONDS:g}], got {seconds:g}")
    try:
        session = EngineSession.create(emb, rate=rate, program=program)
    except SessionError as exc:
        raise MotionError(exc.render()) from exc
    ticks = max(2, round(seconds * session.engine.rate))
    raw = np.empty((ticks, len(emb.joint_names)))
    filtered = np.empty_like(raw)
    try:
        for k, frame in enumerate(session.run_headless(ticks, timeline)):
            before = frame.stage1 if frame.stage1 is not None else frame.program
            raw[k] = emb.joint_positions(before if before is not None else frame.position)
            filtered[k] = frame.joint_values(emb)
    except ValueError as exc:  # a timed command the program refuses (e.g. it has no clip player)
        raise MotionError(str(exc)) from exc
    return session.engine.rate, raw, filtered


def clip_stage(robot_name: str) -> dict[str, Any]:
    """The program a clip plays in when its robot has none: the rest pose with the clip added, the
    paper's preset D as stage 2 and the safety limits, so a report means the same on any robot."""
    from backend.graph.builder import ProgramBuilder  # lazy: only robots without programs need it

    b = ProgramBuilder(
        "built-in clip stage", "A clip over the rest pose, preset D, safety.", robot=robot_name
    )
    rest = b.node("rest_pose", "rest", ui={"x": 0, "y": 0})
    gesture = b.node("clip_player", "gesture", ui={"x": 0, "y": 160})
    mix = b.node(
        "layer_mixer",
        "mix",
        ui={"x": 260, "y": 60},
        layers=[{"name": "base"}, {"name": "gesture", "mode": "additive"}],
    )
    nmf = b.node("nmf_stage2", "nmf", ui={"x": 520, "y": 60}, preset="D")
    safety = b.node("safety_limiter", "safety", ui={"x": 780, "y": 60})
    b.connect(rest, mix, "out", "base").connect(gesture, mix, "out", "gesture")
    b.chain(mix, nmf, safety, b.output())
    return b.to_dict()


def clip_motion(
    emb: Embodiment,
    name: str,
    clip: dict[str, Any],
    program: dict[str, Any] | None = None,
    seconds: float | None = None,
    rate: float | None = None,
) -> Motion:
    """The clip played from t = 0 by `program`'s clip player (none: `clip_stage`), at `rate` Hz (None:
    the program's own)."""
    from backend.engine.clips import ClipError, compile_clip  # lazy: the engine's clips are heavy

    try:
        duration = compile_clip(clip, emb).duration
    except ClipError as exc:
        raise MotionError(f"clip '{name}': {exc}") from exc
    play = {"type": "play_clip", "clip": str(clip.get("name") or name), "document": clip}
    stage = program if program is not None else clip_stage(emb.name)
    rate, raw, filtered = run_program(emb, stage, seconds or duration + SETTLE, rate, [(0.0, play)])
    return Motion(name, "clip", rate, raw, filtered)


def program_motion(emb: Embodiment, name: str, program: dict[str, Any], seconds: float) -> Motion:
    rate, raw, filtered = run_program(emb, program, seconds)
    return Motion(name, "program", rate, raw, filtered)
