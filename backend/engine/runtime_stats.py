"""The engine's clock statistics as JSON (`Engine.stats`, /api/status): tick cost and CPU time, period,
lateness, overruns (and the last ones: when, how late the clock woke, how long the tick ran) and lost ticks,
the safety net's counts, the clock's priority and every sink's."""

from __future__ import annotations

import time
from collections import deque
from typing import Any

from backend.engine.profile import CookTimes


def engine_stats(engine: Any) -> dict[str, Any]:
    """`engine` (an Engine)'s statistics."""
    return {
        "rate": engine.rate,
        "ticks": engine.ticks,
        "t": engine.t,
        "level": engine.apu.level if engine.apu else None,
        "max_level": engine.max_level,
        "running": engine.running,
        "overruns": engine.overruns,
        "lost_ticks": engine.lost_ticks,
        # (one C call, like RingStats.summary's: a snapshot the clock can't change)
        "recent_overruns": list(engine.recent_overruns),
        "swaps": engine.swaps,
        "safety": engine.safety.stats(),
        "tick_cost": engine.tick_cost.summary(),
        "tick_cpu": engine.tick_cpu.summary(),
        "period": engine.period.summary(),
        "jitter": engine.lateness.summary(),
        "started_at": engine.started_at,
        "clock_priority": None
        if engine.clock_priority is None
        else {
            "switch_interval_ms": engine.clock_priority.interval * 1e3,
            "nice": engine.clock_priority.nice,
            "realtime": engine.clock_priority.realtime,
        },
        "clock_cpu": None
        if engine.clock_priority is None or engine.clock_priority.cpu is None
        else engine.clock_priority.cpu.status(),
        "sinks": [s.stats() for s in engine.sinks],
        "fan_out": engine.fan_out_stats(),
    }


def retime(apu: Any, every: int, window: int) -> None:
    """Give `apu` (an APU, or None) cook times sampled one tick in `every`, over `window` ticks."""
    if apu is not None and (apu.cook.every, apu.cook.window) != (every, window):
        apu.cook = CookTimes(apu.cook.node_ids, apu.cook.types, every, window)


def reset(engine: Any) -> None:
    """Forget the samples of the tick cost, period, lateness and the program's cook times."""
    for ring in (engine.tick_cost, engine.tick_cpu, engine.period, engine.lateness):
        ring.reset()
    if engine.apu is not None:
        engine.apu.cook.reset()


#: How many overruns `recent_overruns` keeps (the newest last).
RECENT_OVERRUNS = 32


def overrun_ring() -> deque[dict[str, float]]:
    """An empty record of the last `RECENT_OVERRUNS` overruns (see `overran`)."""
    return deque(maxlen=RECENT_OVERRUNS)


def overran(engine: Any, late: float, tick: float, behind: float) -> None:
    """Count an overrun of `engine`'s clock: its tick began `late` s after its deadline, ran `tick` s, and
    ended `behind` s past the next deadline (more than a period: the ticks in between are lost).

    The record says where the time went. A long `tick` is the program's (or the interpreter lock held by
    another thread while it ran); a long `late` with a short tick is a wake the clock did not get in time:
    on a virtual machine the whole machine stalls now and then (a bare sleep loop in a process of its own
    stalls at the same moments: benchmarks/machine_stalls.py), and no program can keep its period then."""
    lost = int(behind // engine.dt)
    engine.overruns += 1
    engine.lost_ticks += lost
    engine.recent_overruns.append(
        {"at": time.time(), "late_ms": late * 1e3, "tick_ms": tick * 1e3, "lost": lost}
    )
