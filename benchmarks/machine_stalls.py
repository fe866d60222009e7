"""The machine's own stalls: a bare sleep loop on every CPU, in processes of their own, beside a served run.

`python benchmarks/machine_stalls.py PERIOD SECONDS` starts one process per CPU this process may use,
each pinned to its CPU at real-time priority (like the served clock), waking every PERIOD s for SECONDS s
and doing nothing else. It prints one JSON line, the CPUs merged:
`{"late_p99_ms": …, "late_max_ms": …, "overruns": …, "wakes": …, "cpus": […], "realtime": …,
"stalls": [[at, late_ms, cpu], …]}`, where `stalls` lists every wake later than one period (`at`: Unix
time of the wake, s) and `overruns` counts them by the engine's rule (a wake that ends more than a whole
period past the next deadline; the loop then re-anchors as the engine does).

Why: on this kind of machine (a virtual machine whose kernel does not preempt kernel code) a CPU now and
then stops running its threads for a few milliseconds: the host runs something else on it, or a task on it
is inside a long system call. Then every thread waiting for that CPU wakes late, whatever its priority, and
a 500 Hz clock overruns however little its tick costs. These loops hold no interpreter lock and do no work,
so what they see is the machine's. A loop on every CPU sees a stall wherever the served clock was.
served.py runs this in the measurement window, and bench_engine.py matches each overrun of the server
(/api/status `recent_overruns`) against the stalls seen at the same moment.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import sys
import time
from typing import Any

import numpy as np
from peer_beside import realtime


def watch(period: float, seconds: float, cpu: int | None = None) -> dict[str, Any]:
    """Wake every `period` s for `seconds` s; the lateness figures, the overruns and the stalls (see the
    module), each stall marked with `cpu` (-1: None). A plain sleep: its own jitter (tens of µs) is far
    below a stall, and it leaves the CPUs to the served run between wakes. The caller pins the process
    and raises its priority (`_watch_on`): this only watches."""
    wakes = max(1, round(seconds / period))
    late = np.empty(wakes)
    stalls: list[list[float]] = []
    overruns = 0
    deadline = time.perf_counter() + period
    for k in range(wakes):
        time.sleep(max(0.0, deadline - time.perf_counter()))
        start = time.perf_counter()
        late[k] = start - deadline
        if late[k] > period:
            stalls.append([time.time(), late[k] * 1e3, -1 if cpu is None else cpu])
        deadline += period
        behind = start - deadline
        if behind > period:  # the engine's rule and re-anchoring (backend/engine/clock_loop.py)
            overruns += 1
            deadline = start + period - math.fmod(behind, period)
    return {
        "late_p99_ms": float(np.percentile(late, 99)) * 1e3,
        "late_max_ms": float(late.max()) * 1e3,
        "overruns": overruns,
        "wakes": wakes,
        "stalls": stalls,
    }


def _watch_on(args: tuple[float, float, int]) -> dict[str, Any]:
    """`watch` in a pool's process pinned to one CPU, at real-time priority where permitted."""
    period, seconds, cpu = args
    os.sched_setaffinity(0, {cpu})
    prioritised = realtime()
    return {**watch(period, seconds, cpu), "realtime": prioritised}


def watch_every_cpu(period: float, seconds: float) -> dict[str, Any]:
    """`watch` on every CPU this process may use at once, merged: the worst lateness, every stall."""
    cpus = sorted(os.sched_getaffinity(0))
    with multiprocessing.get_context("fork").Pool(len(cpus)) as pool:
        each: list[dict[str, Any]] = pool.map(_watch_on, [(period, seconds, c) for c in cpus])
    return {
        "late_p99_ms": max(e["late_p99_ms"] for e in each),
        "late_max_ms": max(e["late_max_ms"] for e in each),
        "overruns": sum(e["overruns"] for e in each),
        "wakes": sum(e["wakes"] for e in each),
        "stalls": sorted(s for e in each for s in e["stalls"]),
        "cpus": cpus,
        "realtime": all(e["realtime"] for e in each),
    }


def coincides(overrun: dict[str, float], stalls: list[list[float]], slack: float = 1e-3) -> bool:
    """Whether a stall (each of `stalls` is `[at, late_ms, cpu]`: a loop's wake at `at` came `late_ms`
    late) overlaps, within `slack` s, the time a served clock's `overrun` lost: from its tick's deadline
    to the tick's end (/api/status `recent_overruns`: the tick ended at `at`, ran `tick_ms`, and began
    `late_ms` after its deadline). A stall the loops saw is longer than a period, so one that overlaps
    the lost time is where it went, whether the clock was waiting then or mid-tick."""
    began = overrun["at"] - overrun["tick_ms"] / 1e3
    lost = (began - overrun["late_ms"] / 1e3, overrun["at"])
    return any(at - late / 1e3 - slack <= lost[1] and lost[0] <= at + slack for at, late, *_ in stalls)


def main(argv: list[str]) -> int:
    period, seconds = float(argv[0]), float(argv[1])
    print(json.dumps(watch_every_cpu(period, seconds)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
