"""The engine's clock loop: wait for each deadline, tick, and count what was late (`Engine.start`).

Each tick runs at its deadline, one period after the last one's. A wake that comes late is counted
(`lateness`); a tick that ends more than a whole period past the next deadline is an overrun: the clock
re-anchors on the next slot rather than bursting to catch up, so time stretches (the robot moves
slower, never faster) and the skipped ticks are counted as lost (`runtime_stats.overran`).
"""

from __future__ import annotations

import math
import threading
import time
from typing import TYPE_CHECKING

from backend.engine import runtime_stats

if TYPE_CHECKING:
    from backend.engine.runtime import Engine


def run(engine: Engine, stop: threading.Event) -> None:
    """Tick `engine` at its rate on its clock until `stop` is set (on the clock's thread)."""
    clock, period = engine.clock, engine.dt
    if engine.started_at is None:
        engine.started_at = time.time()
    deadline = clock.now()
    last_start: float | None = None
    while not stop.is_set() and clock.wait_until(deadline, stop):
        start = clock.now()
        if last_start is not None:
            engine.period.add(start - last_start)
        engine.lateness.add(start - deadline)
        last_start = start
        engine.tick()
        deadline += period
        now = clock.now()
        behind = now - deadline
        if behind > period:
            runtime_stats.overran(engine, start - deadline + period, now - start, behind)
            deadline = now + period - math.fmod(behind, period)
