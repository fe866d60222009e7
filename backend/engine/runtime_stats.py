"""The engine's clock statistics as JSON (`Engine.stats`, /api/status): tick cost and CPU time, period,
lateness, overruns and lost ticks, the safety net's counts, the clock's priority and every sink's."""

from __future__ import annotations

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
