"""The engine's real-time clock on this machine: how steady it ticks, whether a slow sink holds it
back, and how long a hot swap into a ticking engine takes. These were wall-clock asserts in the
tests; the tests now check the clock's logic with a simulated clock and this prints the timing.

- Steadiness: bench_engine's light level-3 program (three layers and the safety limiter) at 200 Hz
  and 1000 Hz for 2 s each: ticks reached, tick period p50/p99, lateness p99, lost ticks, tick cost
  p50 (the program's share). Peer, measured in the same run: a bare `time.sleep(period)` loop (what
  a naive clock gets from the OS). Goal (the old test's bounds): at least 70 % of the
  nominal ticks and the 200 Hz period p50 within 3..7 ms.
- Slow sink: the same at 200 Hz with one sink needing 50 ms per frame next to a fast one. Goal:
  the clock keeps at least 70 % of its nominal ticks and the fast sink gets all but a few frames.
- Swaps: 100 `load_program` calls cycling through the bundled idle, greet and interactive programs
  into the ticking 200 Hz engine (each waits for a tick boundary) next to the same swaps into a
  stopped engine (applied at once), p50/p99 in ms.

Run: .venv/bin/python benchmarks/bench_clock.py
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_engine import three_layer_program
from results import headline, recorded

from backend.engine.embodiment import load_embodiment
from backend.engine.runtime import Sink
from backend.session import EngineSession

SECONDS = 2.0
PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"
SWAP_CYCLE = ("idle", "greet", "interactive")


def program(name: str) -> dict:
    """A bundled nutty_desk program (interactive: what `nutty serve` runs by default)."""
    return json.loads((PROGRAMS / f"{name}.json").read_text())


def run_clock(emb, rate: float, sinks: tuple[Sink, ...] = ()) -> dict:
    """Clock statistics of `SECONDS` of running (after a headless warm-up: first calls compile)."""
    eng = EngineSession.create(emb, rate=rate, program=three_layer_program()).engine
    warm_up = eng.run_ticks(200)
    for sink in sinks:
        eng.add_sink(sink)
    eng.start()
    time.sleep(SECONDS)
    eng.stop()
    stats = eng.stats()
    stats["ticks"] -= len(warm_up)
    eng.close()
    return stats


def sleep_loop(rate: float) -> dict:
    """The peer: sleep one period per tick and take whatever the OS gives."""
    period, periods = 1.0 / rate, []
    end = time.perf_counter() + SECONDS
    last = time.perf_counter()
    while last < end:
        time.sleep(period)
        now = time.perf_counter()
        periods.append(now - last)
        last = now
    ms = np.array(periods) * 1e3
    return {
        "ticks": len(periods),
        "p50_ms": float(np.percentile(ms, 50)),
        "p99_ms": float(np.percentile(ms, 99)),
    }


def report_steadiness(emb) -> None:
    for rate in (200.0, 1000.0):
        s, peer = run_clock(emb, rate), sleep_loop(rate)
        nominal = rate * SECONDS
        period = s["period"]
        ok = s["ticks"] >= 0.7 * nominal and (rate != 200.0 or 3.0 <= period["p50_ms"] <= 7.0)
        print(
            f"clock {rate:6.0f} Hz  ticks {s['ticks']:5d} of {nominal:.0f} ({s['ticks'] / nominal:.0%})   "
            f"period p50 {period['p50_ms']:.3f} p99 {period['p99_ms']:.3f} ms   "
            f"late p99 {s['jitter']['p99_ms']:.3f} ms   lost {s['lost_ticks']}   "
            f"tick cost p50 {s['tick_cost']['p50_ms']:.3f} ms   goal: "
            f"{'meets' if ok else 'MISSES'}   sleep-loop peer: ticks {peer['ticks']} "
            f"({peer['ticks'] / nominal:.0%}), period p50 {peer['p50_ms']:.3f} p99 {peer['p99_ms']:.3f} ms "
            f"(clock/peer p99 {period['p99_ms'] / peer['p99_ms']:.2f}x)"
        )
        headline(
            f"clock at {rate:g} Hz: lateness p99 {s['jitter']['p99_ms']:.3f} ms, period p99 "
            f"{period['p99_ms']:.3f} ms against a bare sleep loop's {peer['p99_ms']:.3f} ms; {s['lost_ticks']} lost"
        )


def report_slow_sink(emb) -> None:
    rate, nominal = 200.0, 200.0 * SECONDS
    fast_frames: list = []
    slow = Sink("slow", lambda f: time.sleep(0.05), max_queue=4)
    fast = Sink("fast", fast_frames.append, max_queue=64)
    s = run_clock(emb, rate, (slow, fast))
    bare = run_clock(emb, rate)
    missing = s["ticks"] - len(fast_frames)
    ok = s["ticks"] >= 0.7 * nominal and missing <= 0.05 * s["ticks"]
    print(
        f"slow sink 200 Hz  ticks {s['ticks']} with a 50 ms sink vs {bare['ticks']} without "
        f"({s['ticks'] / max(bare['ticks'], 1):.2f}x)   slow sink delivered {slow.delivered}, dropped "
        f"{slow.dropped}   fast sink missed {missing}   goal: {'meets' if ok else 'MISSES'}"
    )


def swap_latencies(emb, running: bool) -> np.ndarray:
    session = EngineSession.create(emb, rate=200.0, program=program("interactive"))
    if running:
        session.engine.start()
    costs = []
    try:
        for k in range(1, 101):
            doc = program(SWAP_CYCLE[k % len(SWAP_CYCLE)])
            t0 = time.perf_counter()
            session.load_program(doc)
            costs.append(time.perf_counter() - t0)
            if running:
                time.sleep(0.01)
    finally:
        session.engine.close()
    return np.array(costs) * 1e3


def report_swaps(emb) -> None:
    live, still = swap_latencies(emb, True), swap_latencies(emb, False)
    p50, p99 = np.percentile(live, [50, 99])
    q50, q99 = np.percentile(still, [50, 99])
    print(
        f"swaps into a 200 Hz clock  p50 {p50:.2f} ms  p99 {p99:.2f} ms   into a stopped engine (peer) "
        f"p50 {q50:.2f} ms  p99 {q99:.2f} ms   (live/peer p50 {p50 / q50:.2f}x)"
    )
    headline(f"a program hot-swapped into a running 200 Hz clock: {p50:.1f} ms p50, {p99:.1f} ms p99")


def main() -> None:
    desk = load_embodiment("nutty_desk")
    report_steadiness(desk)
    report_slow_sink(desk)
    report_swaps(desk)


if __name__ == "__main__":
    with recorded("bench_clock", "Real-time clock: steadiness, slow sink, hot swaps"):
        main()
