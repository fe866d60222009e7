"""The engine's clock: where the clock loop reads time and waits (`Clock`, the real `WallClock`), and
the rolling statistics of its timing (`RingStats`: tick cost, period, lateness; `SampledCpu`: the tick's
CPU time).

A clock other than `WallClock`, e.g. a simulated one in tests, drives the same loop without real sleeps.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Protocol

import numpy as np


class RingStats:
    """The last `size` samples of a quantity (seconds), summarised as p50/p99/max in ms.

    `add` is the deque's own `append`, a call into C: the running clock adds three samples a tick (its
    cost, period and lateness), and each Python call costs a tick woken from a sleep ~3-5 µs."""

    def __init__(self, size: int = 4096):
        self._samples: deque[float] = deque(maxlen=size)
        self.add: Callable[[float], None] = self._samples.append

    def reset(self) -> None:
        self._samples.clear()

    def summary(self) -> dict[str, float]:
        # one C call under the interpreter lock: a snapshot the clock can't change
        samples = list(self._samples)
        if not samples:
            return {"p50_ms": 0.0, "p99_ms": 0.0, "max_ms": 0.0, "samples": 0}
        a = np.array(samples) * 1e3
        p50, p99 = np.percentile(a, [50, 99])
        return {"p50_ms": float(p50), "p99_ms": float(p99), "max_ms": float(a.max()), "samples": len(samples)}


class SampledCpu:
    """The clock thread's CPU time in one plain tick of every `every`, into `ring` (seconds).

    A CPU-time reading is a system call (the thread's CPU clock has no vDSO fast path): ~0.5 µs in a
    tight loop, but ~10 µs on a tick woken from a sleep, more than most of a program's Python steps, so
    two on every tick cost a served tick ~5%. A tick that times the blocks one by one, and the one after
    it, cost more than a plain tick and are never read (`plain()` says whether a tick is plain; it is
    asked only on a tick due to be read)."""

    def __init__(self, ring: RingStats, every: int):
        self.ring, self.every = ring, max(1, int(every))
        #: Ticks until the next one read: the caller counts it down by one as each tick starts, and calls
        #: `start` only once it is down to 0 (a plain tick then makes no call).
        self.due = 1

    def start(self, plain: Callable[[], bool] | None) -> float:
        """Call as a tick starts, once `due` is down to 0: the thread's CPU time (s) if this tick is read,
        else -1 (`plain` None: every tick is plain; a tick that is not is skipped, and the next asked)."""
        if plain is not None and not plain():
            return -1.0
        self.due = self.every
        return time.thread_time()

    def stop(self, cpu0: float) -> None:
        """Call as the tick ends with what `start` returned, when it returned a time (>= 0)."""
        self.ring.add(time.thread_time() - cpu0)


class Clock(Protocol):
    """What the engine's clock loop needs from time: a reading and a wait."""

    def now(self) -> float:
        """Seconds on a monotonic scale (any origin)."""
        ...

    def wait_until(self, deadline: float, stop: threading.Event) -> bool:
        """Return at `deadline` (a `now()` reading) with True, or with False once `stop` is set."""
        ...


class WallClock:
    """The real clock: `time.perf_counter`; a wait sleeps, then spins the last `spin` seconds
    (sleep alone is too coarse for a 1 kHz loop)."""

    def __init__(self, spin: float = 0.0003):
        self.spin = spin

    def now(self) -> float:
        return time.perf_counter()

    def wait_until(self, deadline: float, stop: threading.Event) -> bool:
        wait = deadline - time.perf_counter()
        if wait > self.spin and stop.wait(wait - self.spin):
            return False
        while time.perf_counter() < deadline:
            pass
        return not stop.is_set()
