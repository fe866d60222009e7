"""benchmarks/machine_stalls.py: the bare sleep loops that tell the machine's stalls from the server's
overruns in the 500 Hz served benchmark (what bench_engine.py prints beside its overruns)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import machine_stalls  # (benchmarks/ is not a package: its path goes first, above)


def test_a_stalled_wake_is_listed_and_counted_by_the_engines_rule(monkeypatch):
    """A sleep that returns 3.5 periods late (the machine stalled) is one stall and one overrun with
    two ticks' worth lost; the loop then re-anchors and the other wakes are on time."""
    real_sleep, calls = time.sleep, []

    def sleep(s: float) -> None:
        calls.append(s)
        real_sleep(s + (0.035 if len(calls) == 20 else 0.0))

    monkeypatch.setattr(machine_stalls.time, "sleep", sleep)
    policy = os.sched_getscheduler(0)
    out = machine_stalls.watch(0.01, 0.4)
    assert os.sched_getscheduler(0) == policy  # watching leaves the caller's priority alone
    assert out["wakes"] == 40 and out["overruns"] == 1
    ((at, late_ms, cpu),) = out["stalls"]
    assert late_ms == pytest.approx(35, abs=15) and cpu == -1 and abs(at - time.time()) < 5
    assert out["late_max_ms"] == pytest.approx(late_ms)


def test_an_overrun_coincides_with_a_stall_that_overlaps_the_time_it_lost():
    # the server's tick ended at t=100.010 s after 0.5 ms, having woken 4 ms late: from its deadline
    # (100.0055) to its end (100.010) the time was lost
    overrun = {"at": 100.010, "tick_ms": 0.5, "late_ms": 4.0}
    assert machine_stalls.coincides(overrun, [[100.0090, 3.0, 0]])  # a loop woke 3 ms late at 100.009
    assert machine_stalls.coincides(overrun, [[100.0050, 2.5, 1]])  # ended as the server's wait began
    assert not machine_stalls.coincides(overrun, [[100.0300, 3.0, 0]])  # 20 ms later: the server's own
    assert not machine_stalls.coincides(overrun, [[99.9900, 3.0, 0]])  # over 10 ms before its deadline
    assert not machine_stalls.coincides(overrun, [])


def test_a_long_tick_coincides_with_a_stall_while_it_ran():
    """Woken on time, the tick ran 5.4 ms: a stall of the machine in the middle of it is where the time went."""
    overrun = {"at": 200.0, "tick_ms": 5.4, "late_ms": 0.0}
    assert machine_stalls.coincides(overrun, [[199.9995, 2.5, 1]])  # the loop stalled 199.997..199.9995
    assert not machine_stalls.coincides(overrun, [[199.990, 2.5, 1]])  # ended 4.6 ms before the tick began
