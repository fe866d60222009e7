"""The physics preview (backend/sim, `nutty serve --sim mujoco`): what following the engine costs, and
what the motors make of every bundled clip, raw and through the robot's program.

- Follow cost: nutty_desk's interactive program at 100 Hz, each frame followed by the MuJoCo driver
  (10 physics steps at 1 kHz + contact scan + readings) on this thread; CPU µs per frame p50/p99 and
  the share of one core it takes at 100 Hz (the issue's target: <= 30 %). Peer: the engine's own
  `tick()` in the same run.
- Served: `nutty serve --no-previz` at 100 Hz for SECONDS, with and without `--sim mujoco`: the clock's
  tick p50/p99 (the simulation runs on its own thread) and the driver's own measured share of a core.
- Report: `nutty sim report` for every clip of nutty_desk (played by its interactive program), and its
  idle program: the worst joint's peak tracking error raw vs filtered, saturated time, contacts.

Run: .venv/bin/python benchmarks/bench_sim.py
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from results import headline, recorded
from serve_window import served_status

from backend.drivers.registry import DriverArgs
from backend.engine.embodiment import load_embodiment
from backend.session import EngineSession
from backend.sim.driver import MujocoDriver
from backend.sim.model import build, gains_for
from backend.sim.motions import clip_motion, program_motion
from backend.sim.report import physics_report

ROBOT = ROOT / "robots" / "nutty_desk"
RATE = 100.0
FRAMES = 1000
SECONDS = 10.0
WARMUP = 4.0


def follow_cost() -> None:
    emb = load_embodiment(ROBOT)
    session = EngineSession.create(emb, rate=RATE)
    session.load_program((ROBOT / "programs" / "interactive.json").read_text())
    session.engine.run_ticks(100)
    ticks, frames = [], []
    for _ in range(FRAMES):
        t0 = time.thread_time()
        frames.append(session.engine.tick())
        ticks.append(time.thread_time() - t0)
    session.engine.close()
    driver = MujocoDriver.from_option(emb, DriverArgs("mujoco", {}, argparse.Namespace()))
    costs = []
    for frame in frames:
        t0 = time.thread_time()
        driver.consume(frame)
        costs.append(time.thread_time() - t0)
    costs_us = np.asarray(costs[10:]) * 1e6
    tick_us = np.asarray(ticks) * 1e6
    p50, p99 = np.percentile(costs_us, [50, 99])
    share = float(np.mean(costs_us)) * 1e-6 * RATE
    print(f"  follow one frame (10 steps at 1 kHz): {p50:.0f} µs p50, {p99:.0f} µs p99")
    print(f"  share of one core at {RATE:g} Hz: {share * 100:.1f} % (target <= 30 %)")
    headline(
        f"physics preview following nutty_desk at {RATE:g} Hz: {p50:.0f} µs per frame, {share * 100:.1f} % of a core"
    )
    peer = float(np.percentile(tick_us, 50))
    print(f"  peer: engine.tick() (interactive) {peer:.0f} µs p50; follow / tick: {p50 / peer:.2f}x")


def served_pair() -> None:
    plain, sim = served_status([], SECONDS, WARMUP), served_status(["--sim", "mujoco"], SECONDS, WARMUP)
    for label, s in (("without --sim", plain), ("--sim mujoco", sim)):
        tick = s["tick_cost"]
        print(f"  {label:<14s} tick {tick['p50_ms']:.3f} ms p50, {tick['p99_ms']:.3f} ms p99")
    status = sim["simulation"]
    print(
        f"  the simulation's thread: {status['cpu_per_frame_ms']:.3f} ms CPU per frame, "
        f"{status['cpu_share'] * 100:.1f} % of a core; {status['steps']} steps, "
        f"{status['contacts_total']} contacts"
    )
    ratio = sim["tick_cost"]["p50_ms"] / plain["tick_cost"]["p50_ms"]
    print(f"  served tick p50, with / without: {ratio:.2f}x")
    headline(
        f"served with --sim mujoco: the simulation's thread {status['cpu_share'] * 100:.1f} % of a core; "
        f"served tick {ratio:.2f}× without"
    )


def reports() -> None:
    emb = load_embodiment(ROBOT)
    sim = build(emb, gains_for(emb, None))
    program = json.loads((ROBOT / "programs" / "interactive.json").read_text())
    motions = [
        clip_motion(emb, path.stem, json.loads(path.read_text()), program)
        for path in sorted((ROBOT / "clips").glob("*.json"))
    ]
    idle = json.loads((ROBOT / "programs" / "idle.json").read_text())
    motions.append(program_motion(emb, "idle (program, 10 s)", idle, 10.0))
    print(
        f"  {'motion':<22s} {'worst joint':<12s} {'raw err':>8s} {'filtered':>9s} {'sat raw/filt (s)':>17s} contacts"
    )
    for motion in motions:
        report = physics_report(sim, motion.raw, motion.filtered, motion.rate)
        raw, filtered = report["raw"], report["filtered"]
        worst = raw["worst_joint"]
        sat_raw = max(j["saturated"] for j in raw["joints"].values())
        sat_filtered = max(j["saturated"] for j in filtered["joints"].values())
        print(
            f"  {motion.name:<22s} {worst:<12s} {raw['peak_error']:8.4f} "
            f"{filtered['joints'][worst]['peak_error']:9.4f} {sat_raw:8.2f}/{sat_filtered:<8.2f} "
            f"{len(raw['contacts'])}/{len(filtered['contacts'])}"
        )


def main() -> None:
    print(f"Following the engine ({FRAMES} frames of nutty_desk's interactive program):")
    follow_cost()
    print(f"Served at 100 Hz ({SECONDS:g} s after {WARMUP:g} s warm-up):")
    served_pair()
    print("Bundled motions in physics (peak tracking error, rad; raw = before stage 2 and the net):")
    reports()


if __name__ == "__main__":
    with recorded("bench_sim", "Physics preview (MuJoCo): follow cost, the served clock, bundled clips"):
        main()
