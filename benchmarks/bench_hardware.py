"""Real servos on this machine, on the bus emulators (backend/hardware/emulator): what one tick of bus
traffic costs the bus's thread, and what driving them costs the served engine's clock.

- Bus tick: nutty_desk's buses from robots/nutty_desk/hardware.yaml (5 Dynamixel XM430, 2 Feetech
  STS3215, 2 PWM channels on a PCA9685), each opened by its real SDK on its emulator; one tick = one
  `write_goals` + one `read_state` per bus (SYNC WRITE + SYNC READ on the serial buses), p50/p99 in µs
  over TICKS ticks. Peer: nutty_desk's interactive program's `engine.tick()` in the same run. A pty has
  no baud rate: a real 1 Mbaud bus adds the bytes' time and the adapter's latency.
- Served: `nutty serve --no-previz` at 100 Hz for SECONDS after a warm-up, with and without
  `--hardware-emulator robots/nutty_desk/hardware.yaml`: the clock's tick cost p50/p99 and overruns
  from /api/status, and the buses' read rate and missed replies. Ratio: with / without.

Run: .venv/bin/python benchmarks/bench_hardware.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from results import headline, recorded
from serve_window import served_status

from backend.engine.embodiment import load_embodiment
from backend.hardware.config import load_hardware
from backend.hardware.emulated import emulate
from backend.hardware.mapping import JointMap
from backend.session import EngineSession

ROBOT = ROOT / "robots" / "nutty_desk"
HARDWARE = ROBOT / "hardware.yaml"
TICKS = 500
SECONDS = 15.0
WARMUP = 5.0


def percentiles(samples: list[float]) -> tuple[float, float]:
    a = np.asarray(samples) * 1e6
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


def bus_ticks() -> None:
    emb = load_embodiment(ROBOT)
    hardware = load_hardware(HARDWARE, emb)
    buses, emulators = emulate(hardware, emb)
    rest = np.asarray(emb.joint_positions(emb.rest), dtype=float)
    try:
        maps = [JointMap(c, emb) for c in hardware.buses]
        for bus, jmap in zip(buses, maps):
            bus.open()
            bus.ping(jmap.ids)
            bus.torque(jmap.ids, True)
        costs: dict[str, float] = {}
        for bus, jmap in zip(buses, maps):
            times = []
            for i in range(TICKS):
                goals = jmap.to_raw(rest + 0.05 * np.sin(i / 20))
                t0 = time.perf_counter()
                bus.write_goals(jmap.ids, goals)
                bus.read_state(jmap.ids)
                times.append(time.perf_counter() - t0)
            p50, p99 = percentiles(times)
            print(
                f"  {bus.kind:<10s} {len(jmap.ids)} servos: write + read {p50:7.0f} µs p50, {p99:7.0f} µs p99"
            )
            costs[bus.kind] = p50
            headline(
                f"{bus.kind} bus, {len(jmap.ids)} servos: goals + reads {p50:.0f} µs p50 per tick (emulator)"
            )
        for bus, jmap in zip(buses, maps):
            bus.torque(jmap.ids, False)
            bus.close()
    finally:
        for emulator in emulators:
            emulator.close()
    session = EngineSession.create(emb, rate=100.0)
    session.load_program((ROBOT / "programs" / "interactive.json").read_text())
    session.engine.run_ticks(300)
    ticks = []
    for _ in range(TICKS):
        t0 = time.perf_counter()
        session.engine.tick()
        ticks.append(time.perf_counter() - t0)
    session.engine.close()
    p50, p99 = percentiles(ticks)
    print(f"  peer: engine.tick() (interactive, hot) {p50:.0f} µs p50, {p99:.0f} µs p99")
    for kind, cost in costs.items():
        print(f"  {kind} tick / engine tick: {cost / p50:.2f}x (on the bus's own thread, not the clock's)")


def served_pair() -> None:
    plain = served_status([], SECONDS, WARMUP)
    with_hw = served_status(["--hardware-emulator", str(HARDWARE)], SECONDS, WARMUP)
    for label, s in (("without hardware", plain), ("--hardware-emulator", with_hw)):
        tick = s["tick_cost"]
        print(
            f"  {label:<20s} tick {tick['p50_ms']:.3f} ms p50, {tick['p99_ms']:.3f} ms p99, "
            f"{s['overruns_in_window']} overruns in {SECONDS:g} s"
        )
    for bus in with_hw["hardware"]["buses"]:
        print(
            f"    {bus['driver']:<10s} reads {bus['read_hz']:.0f} Hz, missed replies {bus['missed_reads']}, "
            f"goals dropped {bus['dropped']}"
        )
    ratio = with_hw["tick_cost"]["p50_ms"] / plain["tick_cost"]["p50_ms"]
    print(f"  served tick p50, with / without: {ratio:.2f}x")
    headline(
        f"served at 100 Hz with --hardware-emulator: tick {with_hw['tick_cost']['p50_ms']:.2f} ms p50, "
        f"{with_hw['overruns_in_window']} overruns; {ratio:.2f}× without"
    )


def main() -> None:
    print(f"Bus tick on the emulators ({TICKS} ticks):")
    bus_ticks()
    print(f"Served at 100 Hz ({SECONDS:g} s after {WARMUP:g} s warm-up):")
    served_pair()


if __name__ == "__main__":
    with recorded("bench_hardware", "Real servos (on the emulators): bus tick cost and the served clock"):
        main()
