"""The Nutty Motion Filter against Ruckig (the online jerk-limited trajectory generator), in one run.

1. Streaming: N DoFs, a new set-point every cycle, same limits, for N = 1, 25, 100, 1000:
   µs per update for both and the ratio. Targets (issue 3): at 1 DoF no slower than Ruckig; at 25
   DoFs at most 1/5 of Ruckig; at 1000 DoFs at most 1/30.
2. Offline: filtering 10 minutes of a 25-DoF trajectory at 100 Hz; target >= 1000x real time.
3. Motion quality on Φ_L/Φ_R/Φ_C (NMF preset D, order 3, vs Ruckig with the same limits): limit
   violations of the output, overshoot and time to settle, so users see what each buys.

Run: .venv/bin/python benchmarks/bench_nmf.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from backend.engine import nmf_examples as ex  # noqa: E402
from backend.engine.nmf import PRESETS, MotionFilter  # noqa: E402
from backend.engine.trajectory import analyze, overshoot, settle_time  # noqa: E402

try:
    from ruckig import InputParameter, OutputParameter, Ruckig
except ImportError:  # pragma: no cover
    sys.exit("ruckig is not installed: pip install ruckig (the 'bench' extra)")

D = PRESETS["D"]
RATE = 100.0


def time_nmf(n: int, targets: np.ndarray, cycles: int) -> float:
    f = MotionFilter.from_preset("D", n, RATE)
    rows = [np.ascontiguousarray(r) for r in targets]
    f.step(rows[0])
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for k in range(cycles):
            f.step(rows[k % len(rows)])
        best = min(best, (time.perf_counter() - t0) / cycles)
    return best * 1e6


def ruckig_setup(n: int, dt: float):
    otg = Ruckig(n, dt)
    inp, out = InputParameter(n), OutputParameter(n)
    inp.max_velocity = [D.vel_limit] * n
    inp.max_acceleration = [D.acc_limit] * n
    inp.max_jerk = [D.jerk_limit] * n
    inp.current_position = [0.0] * n
    inp.current_velocity = [0.0] * n
    inp.current_acceleration = [0.0] * n
    return otg, inp, out


def time_ruckig(n: int, targets: np.ndarray, cycles: int) -> float:
    otg, inp, out = ruckig_setup(n, 1 / RATE)
    rows = [list(map(float, r)) for r in targets]  # converted once, outside the timed loop
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for k in range(cycles):
            inp.target_position = rows[k % len(rows)]
            otg.update(inp, out)
            out.pass_to_input(inp)
        best = min(best, (time.perf_counter() - t0) / cycles)
    return best * 1e6


def ruckig_follow(setpoints: np.ndarray, rate: float) -> np.ndarray:
    otg, inp, out = ruckig_setup(1, 1 / rate)
    inp.current_position = [float(setpoints[0])]
    pos = np.empty(len(setpoints))
    for k, s in enumerate(setpoints):
        inp.target_position = [float(s)]
        otg.update(inp, out)
        out.pass_to_input(inp)
        pos[k] = out.new_position[0]
    return pos


def main() -> None:
    rng = np.random.default_rng(0)
    print("Streaming, a new set-point every cycle (best of 3), same limits V/A/J = "
          f"{D.vel_limit:g}/{D.acc_limit:g}/{D.jerk_limit:g}")
    print(f"{'DoFs':>6} {'NMF µs':>10} {'Ruckig µs':>10} {'NMF/Ruckig':>11} {'target':>8}  verdict")
    for n, target in ((1, 1.0), (25, 1 / 5), (100, None), (1000, 1 / 30)):
        targets = rng.uniform(-1, 1, size=(256, n))
        cycles = 20000 if n <= 25 else (5000 if n <= 100 else 1000)
        a = time_nmf(n, targets, cycles)
        b = time_ruckig(n, targets, max(200, cycles // 4))
        ratio = a / b
        verdict = "-" if target is None else ("meets" if ratio <= target else "MISSES")
        tgt = "-" if target is None else f"<= {target:.3g}"
        print(f"{n:>6} {a:>10.2f} {b:>10.2f} {ratio:>11.3f} {tgt:>8}  {verdict}")

    n, seconds = 25, 600
    traj = np.cumsum(rng.normal(0, 0.02, size=(int(seconds * RATE), n)), axis=0)
    f = MotionFilter.from_preset("D", n, RATE)
    f.run(traj[:10])
    t0 = time.perf_counter()
    f.run(traj)
    elapsed = time.perf_counter() - t0
    factor = seconds / elapsed
    print(f"\nOffline: 10 min of {n} DoFs at {RATE:g} Hz filtered in {elapsed * 1e3:.1f} ms = "
          f"{factor:,.0f}x real time (target >= 1000x: {'meets' if factor >= 1000 else 'MISSES'})")

    print("\nMotion quality on the paper's inputs (60 Hz; NMF preset D order 3 vs Ruckig, same limits)")
    print(f"{'input':<6} {'filter':<8} {'vel viol.':>9} {'acc viol.':>9} {'jerk viol.':>10} "
          f"{'overshoot':>9} {'settle s':>9}")
    for name, fn in ex.EXAMPLES.items():
        x = fn()
        outs = {"NMF D": MotionFilter.from_preset("D", 1, ex.RATE).run(x[:, None]).position[:, 0],
                "Ruckig": ruckig_follow(x, ex.RATE)}
        for label, y in outs.items():
            res = analyze(np.r_[y[0], y], ex.RATE, D.vel_limit, D.acc_limit, D.jerk_limit)
            c = res.counts()
            # overshoot and settle time of the first step of each input
            change = np.flatnonzero(np.diff(x))
            k0 = int(change[0]) + 1 if change.size else 0
            k1 = int(change[1]) + 1 if change.size > 1 else len(x)
            seg = y[k0:k1]
            ov = overshoot(seg, x[k0 - 1] if k0 else x[0], x[k0])
            st = settle_time(seg, x[k0], ex.RATE, 0.05 * max(1e-9, abs(x[k0] - x[k0 - 1] if k0 else 1)))
            print(f"{name:<6} {label:<8} {c['velocity']:>9} {c['acceleration']:>9} {c['jerk']:>10} "
                  f"{ov:>9.3f} {st:>9.2f}")


if __name__ == "__main__":
    main()
