"""The engine's tick and its peer under the same wake pattern (bench_engine.py's `Wake` table).

A tight loop keeps every cache warm; a real clock sleeps between ticks, and wakes to caches the rest of
the machine has used meanwhile. So both sides are timed the same ways:

- hot: back to back, as a headless loop runs;
- woken: one call after each sleep of the tick's period (2 ms at 500 Hz, 10 ms at 100 Hz), as the
  served clock runs.

Side A is `engine.tick()` of a program; side B one Ruckig streaming update of 25 DoFs (fresh targets
each call). Both run in interleaved chunks so that drifts in the machine's load touch both alike.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import numpy as np
from bench_nmf import ruckig_setup

from backend.engine import clock_cpu

CHUNK = 50  # calls per side before switching to the other
CALLS = 400  # timed calls per side and pattern


def timed_after_sleep(step: Callable[[int], object], sleep: float, calls: int, start: int = 0) -> np.ndarray:
    """µs of each of `calls` calls of `step(k)`, each after a sleep of `sleep` s (0: back to back)."""
    out = np.empty(calls)
    for k in range(calls):
        if sleep:
            time.sleep(sleep)
        t0 = time.perf_counter()
        step(start + k)
        out[k] = time.perf_counter() - t0
    return out * 1e6


def peer_targets(dofs: int, count: int = 256, seed: int = 0) -> list[list[float]]:
    """`count` seeded target poses of `dofs` values in [-1, 1]: what every Ruckig peer streams towards."""
    rng = np.random.default_rng(seed)
    return [list(map(float, row)) for row in rng.uniform(-1, 1, size=(count, dofs))]


def ruckig_step(dofs: int, targets: list[list[float]], dt: float) -> Callable[[int], object]:
    """One streaming update towards the next of `targets` per call (its own state carried over)."""
    otg, inp, out = ruckig_setup(dofs, dt)

    def step(k: int) -> object:
        inp.target_position = targets[k % len(targets)]
        result = otg.update(inp, out)
        out.pass_to_input(inp)
        return result

    return step


def side_by_side(
    tick: Callable[[int], object], peer: Callable[[int], object], sleep: float
) -> tuple[np.ndarray, np.ndarray]:
    """(tick µs, peer µs) over CALLS calls each, alternating chunks of CHUNK."""
    a, b = [], []
    for start in range(0, CALLS, CHUNK):
        a.append(timed_after_sleep(tick, sleep, CHUNK, start))
        b.append(timed_after_sleep(peer, sleep, CHUNK, start))
    return np.concatenate(a), np.concatenate(b)


class _Box:
    __slots__ = ("value",)

    def __init__(self, value: float):
        self.value = value


def scattered_objects(n: int, among: int = 200_000, seed: int = 0) -> tuple[list[_Box], list[_Box]]:
    """`n` small objects picked at random among `among` made one after another (and all kept alive):
    what a tick of a long-running Python program reads, objects that lie far apart in its heap.
    Returns (the picked ones, all of them)."""
    every = [_Box(float(i)) for i in range(among)]
    picks = np.random.default_rng(seed).choice(among, n, replace=False)
    return [every[i] for i in picks], every


def read_all(objects: list[_Box]) -> float:
    """One attribute of each object: the least a tick does with the objects it touches."""
    total = 0.0
    for box in objects:
        total += box.value
    return total


def side_by_side_on_own_cpu(
    tick: Callable[[int], object], peer: Callable[[int], object], sleep: float
) -> tuple[np.ndarray, np.ndarray, dict] | None:
    """`side_by_side` on a thread of its own on a CPU of its own kept out of idle states, as
    `nutty serve --clock-cpu auto` runs the clock (backend/engine/clock_cpu.py): (tick µs, peer µs, the
    CPU's status), or None on a machine with one CPU."""
    cpu = clock_cpu.choose("auto")
    if cpu is None:
        return None
    held = clock_cpu.ClockCpu(cpu).open()
    out: list[np.ndarray] = []
    failed: list[BaseException] = []

    def run() -> None:
        held.pin()
        try:
            out.extend(side_by_side(tick, peer, sleep))
        except BaseException as exc:  # raised again on the caller's thread, below
            failed.append(exc)

    try:
        thread = threading.Thread(target=run, name="own-cpu")
        thread.start()
        thread.join()
    finally:
        status = held.status()
        held.close()
    if failed:
        raise failed[0]
    return out[0], out[1], status


def wake_rows(
    ticks: dict[str, Callable[[int], object]],
    peer: Callable[[int], object],
    patterns: tuple[tuple[str, float], ...],
) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """(program, pattern, tick µs, peer µs) for every program and wake pattern."""
    rows = []
    for label, sleep in patterns:
        for name, tick in ticks.items():
            a, b = side_by_side(tick, peer, sleep)
            rows.append((name, label, a, b))
    return rows


def print_wake(rows: list[tuple[str, str, np.ndarray, np.ndarray]], dofs: int) -> None:
    print(
        f"\nWake pattern: engine.tick() and one Ruckig update of {dofs} DoFs timed alike, back to back "
        f"(hot) and after each sleep of the tick's period (woken), interleaved in chunks of {CHUNK}"
    )
    print(
        f"{'program':<30} {'pattern':<16} {'tick p50':>9} {'p99':>8} {'Ruckig p50':>11} {'p99':>7} "
        f"{'p50 ratio':>9} {'p99 ratio':>9}"
    )
    for name, label, a, b in rows:
        (a50, a99), (b50, b99) = np.percentile(a, [50, 99]), np.percentile(b, [50, 99])
        print(
            f"{name:<30} {label:<16} {a50:>9.1f} {a99:>8.1f} {b50:>11.1f} {b99:>7.1f} "
            f"{a50 / b50:>8.2f}x {a99 / b99:>8.2f}x"
        )
