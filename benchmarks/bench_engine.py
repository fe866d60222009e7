"""Tick cost of a Level 2 program with 3 layers (+ a stage-2 safety limiter) on the default robot
and on a synthetic 1000-DoF robot.

Targets (issue 2): p99 tick cost < 0.5 ms on the default robot (a 1 kHz loop keeps half its budget
free) and < 5 ms on 1000 DoFs. The peer measured in the same run is the bare numpy arithmetic of
the same three layers (no blocks, no APU), so the printed overhead ratio shows what the engine's
structure costs on top of the maths.

Run: .venv/bin/python benchmarks/bench_engine.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from backend.engine.embodiment import load_embodiment  # noqa: E402
from backend.engine.runtime import Engine  # noqa: E402
from backend.graph.builder import ProgramBuilder  # noqa: E402
from backend.graph.compiler import compile_or_raise  # noqa: E402


def synthetic_urdf(n: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l0"/><child link="l{i + 1}"/><axis xyz="0 0 1"/>'
        f'<limit lower="-1" upper="1" velocity="2" effort="1"/></joint>' for i in range(n))
    return f'<?xml version="1.0"?><robot name="many{n}">{links}{joints}</robot>'


def three_layer_program() -> dict:
    b = ProgramBuilder("bench-l2")
    rest = b.node("rest_pose", "rest")
    breathe = b.node("sine", "breathe", dofs=["*"], amplitude=0.05, frequency=0.3, phase_spread=0.1)
    gesture = b.node("sine", "gesture", dofs=["*"], amplitude=0.4, frequency=1.0)
    gain = b.node("gain_offset", "gain", gain=0.8)
    mix = b.node("layer_mixer", "mix", layers=[
        {"name": "base"}, {"name": "idle", "mode": "additive"},
        {"name": "gesture", "mode": "override", "weight": 0.7}])
    safety = b.node("safety_limiter", "safety")
    b.connect(rest, mix, "out", "base").connect(breathe, mix, "out", "idle")
    b.chain(gesture, gain)
    b.connect(gain, mix, "out", "gesture")
    b.chain(mix, safety, b.output())
    return b.to_dict()


def measure_engine(emb, ticks: int) -> np.ndarray:
    eng = Engine(emb, rate=1000)
    eng.load(compile_or_raise(three_layer_program(), emb).apu)
    eng.run_ticks(200)  # warm-up
    costs = np.empty(ticks)
    for k in range(ticks):
        t0 = time.perf_counter()
        eng.tick()
        costs[k] = time.perf_counter() - t0
    return costs * 1e3


def measure_peer(n: int, ticks: int) -> np.ndarray:
    """The same arithmetic as bare numpy: three layers, override + additive, clip, slew."""
    rest = np.zeros(n)
    lo, hi, vmax = -np.ones(n), np.ones(n), np.full(n, 2.0)
    last = rest.copy()
    spread = np.arange(n) * 0.1
    costs = np.empty(ticks)
    phi1 = phi2 = 0.0
    for k in range(ticks):
        t0 = time.perf_counter()
        idle = rest + 0.05 * np.sin(phi1 + spread)
        gesture = 0.8 * (rest + 0.4 * np.sin(phi2))
        out = rest + 0.7 * (gesture - rest)
        out = out + (idle - rest)
        target = np.clip(out, lo, hi)
        last = last + np.clip(target - last, -vmax * 0.001, vmax * 0.001)
        phi1 += 0.002
        phi2 += 0.006
        costs[k] = time.perf_counter() - t0
    return costs * 1e3


def report(name: str, costs: np.ndarray, peer: np.ndarray, target_ms: float) -> None:
    p50, p99, mx = np.percentile(costs, 50), np.percentile(costs, 99), costs.max()
    peer99 = np.percentile(peer, 99)
    verdict = "meets" if p99 < target_ms else "MISSES"
    print(f"{name:<28} p50 {p50:7.3f} ms   p99 {p99:7.3f} ms   max {mx:7.3f} ms   "
          f"target p99 < {target_ms:g} ms: {verdict} ({p99 / target_ms:.2f} of target)   "
          f"bare-numpy peer p99 {peer99:.3f} ms (engine/peer {p99 / peer99:.1f}x)")


def main() -> None:
    ticks = 5000
    desk = load_embodiment("nutty_desk")
    report(f"default robot ({desk.n_channels} ch)", measure_engine(desk, ticks),
           measure_peer(desk.n_channels, ticks), 0.5)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "many.urdf"
        path.write_text(synthetic_urdf(1000))
        many = load_embodiment(path)
    report(f"synthetic robot ({many.n_channels} DoFs)", measure_engine(many, 2000),
           measure_peer(many.n_channels, 2000), 5.0)


if __name__ == "__main__":
    main()
