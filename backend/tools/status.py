"""What the robot is doing, for an AI's get_status: per layer what plays (clip, command id, progress),
the posture move, where it is asked to look and where it looks now, its mood and inputs, the layers'
weights, what the drivers measure at the motors (when one reads them) and the engine's health.

Built from public state only (ClipPlayer.playing, Posture.move_status, LayerMixer.layer_states, the
exposed inputs, Engine.stats), read in one clock-thread call so it describes one moment.
"""

from __future__ import annotations

import math
from typing import Any

from backend.control.session_view import CommandSession
from backend.control.targets import blocks_of, layer_members, layers_of, mixers
from backend.drivers.readings import hardware_status, joint_readings, simulation_status
from backend.engine.blocks.clip_player import ClipPlayer
from backend.engine.blocks.posture import Posture as PostureBlock
from backend.tools.observe import gaze_now, measured

GAZE_FRAME = "m, robot base frame: x forward, y left, z up"


def robot_status(session: CommandSession) -> dict[str, Any]:
    """The status document (JSON) of `session`, an EngineSession."""

    def read() -> tuple[list, list, dict, dict, dict | None]:
        members = layer_members(session)
        players = [
            {
                "node": b.node_id,
                "layers": layers_of(session, b.node_id, members),
                **(b.playing() or {"clip": None}),
            }
            for b in blocks_of(session, ("clip_player",))
            if isinstance(b, ClipPlayer)
        ]
        moves = [
            {"node": b.node_id, "layers": layers_of(session, b.node_id, members), "move": b.move_status()}
            for b in blocks_of(session, ("posture",))
            if isinstance(b, PostureBlock)
        ]
        layers = {
            m.node_id: [
                {
                    "name": s["name"],
                    "mode": s["mode"],
                    "active": s["active"],
                    "weight": round(s["effective"], 3),
                }
                for s in m.layer_states()
            ]
            for m in mixers(session)
        }
        inputs = dict(session.engine.ctx.inputs)
        looking = gaze_now(session, session.engine.last_frame, inputs.get("gaze_target"))
        return players, moves, layers, inputs, looking

    players, moves, layers, inputs, looking = session.engine.call(read)
    inputs = {name: _json(v) for name, v in inputs.items()}
    program = session.program
    declared = {i.name for i in program.inputs} if program is not None else set()
    return {
        "robot": session.embodiment.name,
        "program": program.name if program is not None else None,
        "playing": players,
        "posture": moves,
        "gaze": {"target": inputs.get("gaze_target"), **(looking or {}), "units": GAZE_FRAME}
        if "gaze_target" in declared
        else None,
        "measured": measured(session),
        "joints": joint_readings(session.engine.sinks),
        "hardware": hardware_status(session.engine.sinks),
        "simulation": simulation_status(session.engine.sinks),
        "mood": {n: inputs[n] for n in ("valence", "arousal") if n in declared and n in inputs} or None,
        "inputs": inputs,
        "layers": layers,
        "health": health(session.engine.stats()),
    }


def health(stats: dict[str, Any]) -> dict[str, Any]:
    """The engine's health in a few numbers (the whole of it is GET /api/status)."""
    safety = stats.get("safety", {})
    return {
        "running": stats.get("running"),
        "rate": stats.get("rate"),
        "level": stats.get("level"),
        "tick_p99_ms": round(stats.get("tick_cost", {}).get("p99_ms", 0.0), 3),
        "overruns": stats.get("overruns"),
        "lost_ticks": stats.get("lost_ticks"),
        "safety": {"enabled": safety.get("enabled"), "correcting": safety.get("correcting", [])},
    }


def _json(value: Any) -> Any:
    """An input value as JSON: arrays and numpy numbers as plain lists and floats, non-finite as null."""
    if hasattr(value, "tolist"):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [_json(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
