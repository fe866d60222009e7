"""Keeping the server's threads from holding up the engine's clock: CPython's interpreter lock (the
GIL) handed over quickly, and the clock thread first in line for a CPU.

In `nutty serve` the clock shares the interpreter with the HTTP/WebSocket event loop, the sinks'
threads and the Pre-Viz. When the clock wakes for a tick while another thread runs Python, it waits
until that thread lets the lock go, which CPython forces only after the *switch interval* (5 ms by
default): at 500 Hz that alone can overrun a 2 ms period. And on a busy machine the clock thread, once
runnable, may wait for a CPU behind the server's own threads.

`ClockPriority.apply()` (run on the clock thread when it starts) sets a short switch interval
(`SWITCH_INTERVAL`), so another thread gives the lock back within about that long once the clock asks,
and lowers the clock thread's nice value by `NICE_BOOST` where the OS allows it (Linux: root or
CAP_SYS_NICE; elsewhere nothing changes), so the scheduler prefers it when it wakes; it sleeps most
of each period, so this takes little from the others. The interval is process-wide: the last clock to
stop (`restore()`) puts back the one found before the first started.

What this cannot do: a thread that holds the lock while the OS has preempted it (a machine with more
runnable threads than cores) keeps the clock waiting until it runs again. benchmarks/bench_engine.py
reports the clock's waits next to its own CPU time (`tick_cost` against `tick_cpu` in /api/status).
"""

from __future__ import annotations

import os
import sys
import threading

#: Switch interval (s) while a clock runs: the longest another running thread keeps the lock once asked.
SWITCH_INTERVAL = 0.0005
#: How much the clock thread's nice value is lowered (higher priority), where permitted.
NICE_BOOST = 10


class ClockPriority:
    """The clock thread's claim on the interpreter lock and the CPU (see the module doc).

    `nice` is the nice value the clock thread got (None: unchanged: not permitted, or not Linux)."""

    # Clocks running now and the interval found before the first of them: the last one to stop restores it.
    _running = 0
    _saved = 0.005
    _lock = threading.Lock()

    def __init__(self, interval: float = SWITCH_INTERVAL, nice_boost: int = NICE_BOOST):
        self.interval, self.nice_boost = interval, nice_boost
        self.applied = False
        self.nice: int | None = None

    def apply(self) -> None:
        """On the clock thread, before its first tick."""
        with ClockPriority._lock:
            if ClockPriority._running == 0:
                ClockPriority._saved = sys.getswitchinterval()
            ClockPriority._running += 1
            sys.setswitchinterval(min(sys.getswitchinterval(), self.interval))
        self.applied = True
        if self.nice_boost and hasattr(os, "setpriority") and sys.platform.startswith("linux"):
            tid = threading.get_native_id()  # on Linux a thread's own id takes per-thread priority
            try:
                nice = os.getpriority(os.PRIO_PROCESS, tid) - self.nice_boost
                os.setpriority(os.PRIO_PROCESS, tid, nice)
                self.nice = nice
            except OSError:  # not permitted: the clock runs at the process's priority
                self.nice = None

    def restore(self) -> None:
        if not self.applied:
            return
        self.applied = False
        with ClockPriority._lock:
            ClockPriority._running -= 1
            if ClockPriority._running == 0:
                sys.setswitchinterval(ClockPriority._saved)
