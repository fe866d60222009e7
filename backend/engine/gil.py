"""Keeping the server's threads from holding up the engine's clock: CPython's interpreter lock (the
GIL) handed over quickly, and the clock thread first in line for a CPU.

In `nutty serve` the clock shares the interpreter with the HTTP/WebSocket event loop, the sinks'
threads and the Pre-Viz. When the clock wakes for a tick while another thread runs Python, it waits
until that thread lets the lock go, which CPython forces only after the *switch interval* (5 ms by
default): at 500 Hz that alone can overrun a 2 ms period. And on a busy machine the clock thread, once
runnable, may wait for a CPU behind the server's own threads.

`ClockPriority.apply()` (run on the clock thread when it starts) sets a short switch interval
(`SWITCH_INTERVAL`), so another thread gives the lock back within about that long once the clock asks,
and raises the clock thread's scheduling priority where the OS allows it (Linux: root, CAP_SYS_NICE
or an RLIMIT_RTPRIO; elsewhere nothing changes): real-time scheduling first (`SCHED_FIFO` at
`REALTIME_PRIORITY`, what robot control loops use: the thread runs the moment it wakes), else a nice
value lowered by `NICE_BOOST`. It sleeps most of each period, so this takes little from the others,
and Linux keeps real-time threads below 95 % of a CPU by default. Threads and processes the clock
thread starts get the normal policy (`SCHED_RESET_ON_FORK`). `NUTTY_CLOCK_REALTIME=0` in the
environment keeps the clock off the real-time policy. The interval is process-wide: the last clock to
stop (`restore()`) puts back the one found before the first started.

Why both (issue 15; `nutty serve` at 500 Hz under the full served load): SCHED_FIFO left the clock
far less late, with far fewer overruns, than the nice value alone. Then the other threads' long calls
into C (the Pre-Viz posing, encoding telemetry with the standard library's json) kept the clock
waiting whatever the interval. Once those went (backend/previz_process.py, backend/safe_json.py), the
interval is what bounds the clock's wait: a shorter one left the clock less late down to
`SWITCH_INTERVAL`; a shorter one still lets other threads cut into ticks often enough to lengthen the
tick itself. The figures: benchmarks/RESULTS.md.

The cyclic garbage collector is the other long holder of the lock: a full collection walks every
tracked object (hundreds of thousands once the server has imported FastAPI, pydantic, numba and the
blocks), on the server's event-loop thread, for many clock periods at 500 Hz; the ticks lost came
mostly in the first seconds, while the server imports what it needs after the first frame.
`settle_heap()` collects once and then moves everything alive out of the collector's sight
(`gc.freeze`): later full collections walk only what was made since (benchmarks/bench_design.py
measures both). `collector_paused()` keeps the
collector off while a block of imports runs beside a live clock and settles the heap after it.

What this cannot do: a thread that holds the lock while the OS has preempted it (a machine with more
runnable threads than cores) keeps the clock waiting until it runs again. benchmarks/bench_engine.py
reports the clock's waits next to its own CPU time (`tick_cost` against `tick_cpu` in /api/status).
Nor can it help when the machine stops a CPU for milliseconds (a virtual machine's host, a kernel that
does not preempt its own code): every thread waiting for that CPU wakes late. /api/status keeps the last
overruns with how late the clock woke and how long the tick ran (`recent_overruns`), and the benchmark
sets them against bare sleep loops on every CPU (benchmarks/machine_stalls.py).
"""

from __future__ import annotations

import contextlib
import gc
import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from backend.engine.clock_cpu import ClockCpu

#: Switch interval (s) while a clock runs: the longest another running thread keeps the lock once asked.
SWITCH_INTERVAL = 0.0002
#: How much the clock thread's nice value is lowered (higher priority), where permitted.
NICE_BOOST = 10
#: The clock thread's SCHED_FIFO priority (1..99) where permitted; 0: never real-time.
REALTIME_PRIORITY = 10
#: Environment switch: "0" keeps the clock thread off the real-time policy.
REALTIME_ENV = "NUTTY_CLOCK_REALTIME"


class ClockPriority:
    """The clock thread's claim on the interpreter lock and the CPU (see the module doc).

    `nice` is the nice value the clock thread got (None: unchanged: not permitted, or not Linux);
    `realtime` its SCHED_FIFO priority (None: not real-time). `cpu`, when set before the clock starts
    (`nutty serve --clock-cpu`), is the CPU the clock thread moves to (backend/engine/clock_cpu.py)."""

    # Clocks running now and the interval found before the first of them: the last one to stop restores it.
    _running = 0
    _saved = 0.005
    _lock = threading.Lock()

    def __init__(
        self,
        interval: float = SWITCH_INTERVAL,
        nice_boost: int = NICE_BOOST,
        realtime_priority: int = REALTIME_PRIORITY,
    ):
        self.interval, self.nice_boost = interval, nice_boost
        self.realtime_priority = realtime_priority if os.environ.get(REALTIME_ENV, "1") != "0" else 0
        self.applied = False
        self.nice: int | None = None
        self.realtime: int | None = None
        self._tid: int | None = None
        self.cpu: ClockCpu | None = None

    def apply(self) -> None:
        """On the clock thread, before its first tick."""
        with ClockPriority._lock:
            if ClockPriority._running == 0:
                ClockPriority._saved = sys.getswitchinterval()
            ClockPriority._running += 1
            sys.setswitchinterval(min(sys.getswitchinterval(), self.interval))
        self.applied = True
        if not sys.platform.startswith("linux"):
            return
        tid = self._tid = threading.get_native_id()  # on Linux a thread's own id takes per-thread priority
        if self.cpu is not None:
            self.cpu.pin()
        if self.nice_boost and hasattr(os, "setpriority"):
            try:
                nice = os.getpriority(os.PRIO_PROCESS, tid) - self.nice_boost
                os.setpriority(os.PRIO_PROCESS, tid, nice)
                self.nice = nice
            except OSError:  # not permitted: the clock runs at the process's priority
                self.nice = None
        if self.realtime_priority and hasattr(os, "sched_setscheduler"):
            policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
            try:
                os.sched_setscheduler(tid, policy, os.sched_param(self.realtime_priority))
                self.realtime = self.realtime_priority
            except OSError:  # not permitted: the nice value above is what it gets
                self.realtime = None

    def restore(self) -> None:
        if not self.applied:
            return
        self.applied = False
        if self.realtime is not None and self._tid is not None:
            # back to the normal policy (its nice value stays: the thread is about to end); OSError: not
            # permitted any more, or the thread has gone, and its policy with it
            with contextlib.suppress(OSError):
                os.sched_setscheduler(self._tid, os.SCHED_OTHER, os.sched_param(0))
            self.realtime = None
        with ClockPriority._lock:
            ClockPriority._running -= 1
            if ClockPriority._running == 0:
                sys.setswitchinterval(ClockPriority._saved)


def settle_heap(collect: bool = True) -> None:
    """Collect the garbage there is now (unless `collect` is False: a collection stops the world for as
    long as it walks the heap, too long beside a running clock) and freeze every object still alive
    into the collector's permanent generation, so later collections never walk them again. For the
    moment a long-lived process has built what it keeps: after loading, before serving."""
    if collect:
        gc.collect()
    gc.freeze()


@contextmanager
def collector_paused() -> Iterator[None]:
    """No cyclic collection while the block runs (imports beside a running clock make enough objects to
    trigger full collections of tens of milliseconds); the objects it made are frozen after it without
    a collection, its few cycles of garbage kept for good rather than walked with the lock held."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        settle_heap(collect=False)
        if enabled:
            gc.enable()
