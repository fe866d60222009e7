"""Ruckig-25 woken beside a served run: the served tick's peer in the same window, under the same load.

`python benchmarks/peer_beside.py PERIOD SECONDS` makes one Ruckig streaming update of 25 DoFs after each
sleep of PERIOD s, as many as SECONDS s of periods hold, in a process of its own, and prints its figures as one JSON line:
`{"p50_us": …, "p99_us": …, "updates": …}`. served.py starts it when its measurement window opens.

Why beside the server and not before it: a woken tick pays for what the rest of the machine did to the
caches while it slept, and under the served load (the Pre-Viz, the clients, the server's other threads)
the machine does more than when it is quiet. A peer timed on a quiet machine gets cheaper wakes than the
served tick it is compared with. Timed in the same window it wakes to the same machine. Like the served
clock it runs at real-time priority where the OS allows (backend/engine/gil.py), so both run the moment
they wake and neither is preempted by the server's ordinary threads.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np
from wake import peer_targets, ruckig_step, timed_after_sleep

from backend.engine.gil import REALTIME_PRIORITY

#: Ruckig's size: bench_engine.py's `Peer` (and its targets: `peer_targets`).
DOFS = 25
#: Updates before timing starts (the first ones plan from rest).
WARM_UP = 200


def realtime() -> bool:
    """Real-time priority for this process, as the served clock gets; False where not permitted."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(REALTIME_PRIORITY))
    except (AttributeError, OSError):  # no SCHED_FIFO here, or not permitted
        return False
    return True


def woken(period: float, seconds: float) -> dict[str, float]:
    """The update's µs after each sleep of `period` s, for `seconds` s of periods: p50, p99 and the count."""
    step = ruckig_step(DOFS, peer_targets(DOFS), period)
    for k in range(WARM_UP):
        step(k)
    us = timed_after_sleep(step, period, max(1, round(seconds / period)), start=WARM_UP)
    return {"p50_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)), "updates": len(us)}


def main(argv: list[str]) -> int:
    period, seconds = float(argv[0]), float(argv[1])
    prioritised = realtime()
    figures: dict[str, float | bool] = {**woken(period, seconds), "realtime": prioritised}
    print(json.dumps(figures), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
