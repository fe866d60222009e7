"""A behaviour played offline, through a scratch copy of the running program: what the editor previews
in the Pre-Viz and plays back with the browser's audio, frame for frame what the robot would do (the
same program, layers, stage 2 and safety net), without touching the robot."""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.behaviours.plan import Plan
from backend.engine.embodiment import DofType

WARM_UP = 0.5  # s the scratch program runs before the behaviour starts (idle motion under way)
TAIL = 0.5  # s rendered after the plan's end (follow-through, settling)
MAX_SECONDS = 120.0


def render(session: Any, plan: Plan, name: str, rate: float = 30.0) -> dict[str, Any]:
    """Play `plan` on a scratch session of `session`'s robot and program; frames at `rate` Hz."""
    from backend.session import EngineSession  # the session imports the player, which this module serves

    engine = session.engine
    scratch = EngineSession.create(session.embodiment, rate=engine.rate, program=session.program)
    scratch.engine.ctx.inputs.update(dict(engine.ctx.inputs))
    scratch.engine.run_ticks(round(WARM_UP * engine.rate))
    scratch.notes.clear()
    scratch.behaviours.play(plan, "preview", name)
    emb = scratch.embodiment
    dofs = [d for d in emb.dofs if d.type is not DofType.event]
    seconds = min(plan.duration + TAIL, MAX_SECONDS)
    ticks = int(np.ceil(seconds * engine.rate)) + 1
    every = max(1, round(engine.rate / rate))
    frames, events, t0 = [], [], None
    for k in range(ticks):
        frame = scratch.engine.tick()
        if t0 is None:
            t0 = frame.t
        for ev in frame.events:
            events.append({"t": round(frame.t - t0, 4), **ev.to_dict()})
        if k % every == 0:
            frames.append([_value(d, frame.position) for d in dofs])
    items = [
        {k: v for k, v in n.items() if k not in ("node", "event", "command_id")}
        for n in scratch.notes
        if n.get("node") == "behaviour" and n.get("event") == "item"
    ]
    scratch.engine.close()
    return {
        "rate": engine.rate / every,
        "duration": round(plan.duration, 4),
        "dofs": [d.name for d in dofs],
        "frames": frames,
        "events": events,
        "items": [p.to_dict() for p in plan.items],
        "item_events": items,
    }


def _value(dof: Any, position: np.ndarray) -> Any:
    sl = dof.channels
    if dof.type is DofType.colour:
        return [round(float(c), 4) for c in position[sl]]
    if dof.type is DofType.enum:
        options = dof.options or ()
        i = round(float(position[sl.start]))
        return options[i] if 0 <= i < len(options) else i
    return round(float(position[sl.start]), 5)
