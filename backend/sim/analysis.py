"""The physics part of POST /api/analyze (`physics: true`, the Blender add-on's Check limits) and of the
import report: a clip run headless through the running program's clip player, or the built-in clip
stage when that program has none, and simulated raw and filtered (backend/sim/report.py).

The motors' gains are those of the server's own physics preview when it runs one (`--sim mujoco`,
perhaps with `--sim-hardware`), else the URDF's.
"""

from __future__ import annotations

from typing import Any

from backend.drivers.readings import first_method
from backend.engine.embodiment import Embodiment
from backend.sim.availability import require_mujoco


def clip_physics(
    emb: Embodiment,
    clip: dict[str, Any],
    program: dict[str, Any] | None = None,
    rate: float | None = None,
    sinks: Any = (),
    hardware: Any = None,
) -> dict[str, Any]:
    """api_types.PhysicsReport of `clip` played by `program`'s clip player (none, or a program without
    one: the built-in clip stage). SimUnavailable without MuJoCo; MotionError for a clip or program
    that cannot run; SimError for a robot MuJoCo cannot model."""
    require_mujoco()
    from backend.sim.model import build, gains_for  # lazy: MuJoCo is an optional extra
    from backend.sim.motions import clip_motion
    from backend.sim.report import physics_report

    running = first_method(sinks, "physics_model")
    if running is not None:
        sim, gains = running()
    else:
        sim, gains = build(emb, gains_for(emb, hardware)), "hardware.yaml" if hardware else "urdf"
    stage = program if program is not None and _plays_clips(program) else None
    motion = clip_motion(emb, str(clip.get("name") or "clip"), clip, stage, rate=rate)
    return physics_report(sim, motion.raw, motion.filtered, motion.rate, gains=gains)


def _plays_clips(program: dict[str, Any]) -> bool:
    nodes = program.get("nodes") or []
    subgraphs = program.get("subgraphs") or {}
    found = any(isinstance(n, dict) and n.get("type") == "clip_player" for n in nodes)
    return found or any(_plays_clips(sub) for sub in subgraphs.values() if isinstance(sub, dict))
