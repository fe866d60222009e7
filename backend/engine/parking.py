"""Parking: taking the robot to its exact rest pose, standing still, within its limits (shutdown, the
bridge's rest, tests). The program is dropped; the safety net bounds the way there."""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # the engine calls these; only its type is needed here
    from backend.engine.runtime import Engine


def park(engine: Engine, timeout: float = 3.0) -> dict[str, Any]:
    """Bring the robot to its exact rest pose (no program, no display overrides) within its limits.

    Returns once every channel is at rest with zero velocity and acceleration, or at `timeout`
    (s): {"reached_rest", "seconds", "max_error"}. Ticks the engine itself when the clock is not
    running. The program is dropped; load one again to resume.
    """
    t0 = time.perf_counter()
    load = engine.load if engine.running else engine.load_soon  # stopped: the ticks below apply it
    load(None, adopt=False, also=engine.clear_overrides)
    deadline = t0 + max(0.0, timeout)
    ticks_allowed = math.ceil(max(0.0, timeout) * engine.rate)
    n = 0
    while not engine.at_rest():
        if engine.running:
            if time.perf_counter() >= deadline:
                break
            time.sleep(min(0.01, engine.dt))
        else:
            if n >= ticks_allowed:
                break
            engine.tick()
            n += 1
    seconds = (time.perf_counter() - t0) if engine.running else n * engine.dt
    error = np.abs(engine.position - engine.embodiment.rest)
    return {
        "reached_rest": engine.at_rest(),
        "seconds": seconds,
        "max_error": float(error[engine.embodiment.continuous_mask].max(initial=0.0)),
    }


def at_rest(
    apu: Any, transition: Any, seq: int, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, emb: Any
) -> bool:
    """Whether an engine's last frame (`pos`, `vel`, `acc` after `seq` ticks) is the rest pose exactly,
    standing still, with no program (`apu`) or swap (`transition`) going on."""
    return (
        apu is None
        and transition is None
        and seq > 2
        and bool(np.array_equal(pos, emb.rest))
        and not np.any(vel)
        and not np.any(acc)
    )
