"""The engine's safety net: what a swap did to the robot before and after it, how fast the net re-locks,
and what it costs per tick next to one Ruckig update of the same DoFs (the peer, measured in the same run).

- Swap jumps: the bundled interactive program with the gaze turned, then PUT idle/greet/interactive as
  the editor's New/Open would; worst |v|/V, |a|/A, |j|/J of the frames, without (no transition, no
  net: the engine before the safety issue) and with the engine's transition and net.
- Re-lock: a 0.5 rad step riding on a slow wave on nutty_desk's neck, at 30/100/1000 Hz: seconds from
  the step until the output is the program's again, bit for bit.
- Cost: the net's step on the 22-channel default robot, passing through and correcting every DoF.
- Joint stage: what the joint stage (joints composed from own + symbolic DoFs, limited) adds per tick on
  nutty_desk and on a 1000-DoF robot (bench_engine's synthetic URDF), against the channel stage alone
  measured in the same run.

Run: .venv/bin/python benchmarks/bench_safety.py
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from results import headline, recorded

from backend.engine.embodiment import load_embodiment
from backend.engine.safety import SafetyNet
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"


def program(name: str) -> dict:
    return json.loads((PROGRAMS / f"{name}.json").read_text())


def worst(desk, frames, rate) -> dict[str, float]:
    cont = desk.continuous_mask
    p = np.array([f.position for f in frames])[:, cont]
    v = np.diff(p, axis=0) * rate
    a = np.diff(v, axis=0) * rate
    j = np.diff(a, axis=0) * rate
    return {
        "v": (np.abs(v) / desk.vel_limit[cont]).max(),
        "a": (np.abs(a) / desk.acc_limit[cont]).max(),
        "j": (np.abs(j) / desk.jerk_limit[cont]).max(),
    }


def swap_jumps(desk, protected: bool) -> dict[str, float]:
    session = EngineSession.create(desk, rate=100, program=program("interactive"))
    session.engine.safety.enabled = protected
    frames = list(session.run_headless(20))
    session.execute({"type": "set_gaze", "target": [0.4, 0.6, 0.3]})
    frames += list(session.run_headless(250))
    for name in ("idle", "interactive", "greet", "interactive", "idle"):
        if protected:
            session.load_program(program(name))
        else:  # the old swap: straight in, no transition
            from backend.graph.compiler import compile_program

            res = compile_program(program(name), desk, ctx=session._scratch_ctx(), rate=100.0)
            for step in res.apu.steps:
                step.block.ctx = session.engine.ctx
            session.engine.load(res.apu, transition=0.0)
        frames += list(session.run_headless(150))
    return worst(desk, frames, 100.0)


def relock_seconds(desk, rate: float) -> float:
    net = SafetyNet(desk, rate)
    i = desk.channel_index["neck_pitch"]
    n = int(5 * rate)
    t = np.arange(n) / rate
    x = np.tile(desk.rest, (n, 1))
    x[:, i] = 0.05 * (1 - np.cos(2 * np.pi * 0.3 * t)) ** 2 / 4 + np.where(t >= 1.0, 0.5, 0.0) - 0.1
    out = np.array([net.step(row) for row in x])
    exact = out[:, i] == x[:, i]
    k0 = int(rate)
    return float(np.argmax(exact[k0:]) / rate) if exact[k0:].any() else float("nan")


def cost_us(desk, kind: str, n: int = 20_000, joints: bool = True) -> float:
    """µs per `SafetyNet.step`: "pass" holds rest, "correct" jumps every DoF to its limit and back every
    50 ticks; `joints=False` runs the channel stage alone (the joint stage given no joints)."""
    net = SafetyNet(desk, 100.0)
    if not joints:
        net._jidx = net._jidx[:0]
    rest = desk.rest.copy()
    far = rest.copy()
    far[desk.continuous_mask] = desk.max[desk.continuous_mask]
    frames = [rest] * n if kind == "pass" else [far if (k // 50) % 2 else rest for k in range(n)]
    for f in frames[:200]:
        net.step(f)
    t0 = time.perf_counter()
    for f in frames:
        net.step(f)
    return (time.perf_counter() - t0) / n * 1e6


def ruckig_us(dofs: int) -> float | None:
    """One Ruckig streaming update of `dofs` DoFs (bench_nmf's peer), best of 5."""
    try:
        from bench_nmf import time_ruckig
    except (ImportError, SystemExit):
        return None
    rows = [list(map(float, r)) for r in np.random.default_rng(0).uniform(-1, 1, size=(256, dofs))]
    return min(time_ruckig(dofs, rows, 2000) for _ in range(5))


def main() -> None:
    desk = load_embodiment("nutty_desk")
    print("swap with the gaze turned (interactive -> idle/greet/... at 100 Hz): worst limit ratio")
    for label, on in (("before (no transition, no net)", False), ("after (transition + net)", True)):
        r = swap_jumps(desk, on)
        print(f"  {label:32s} v {r['v']:7.2f}x  a {r['a']:8.2f}x  j {r['j']:9.2f}x")
        headline(
            f"a program swap with the gaze turned, {label}: worst velocity {r['v']:.2f}×, acceleration "
            f"{r['a']:.2f}×, jerk {r['j']:.2f}× the limits"
        )
    print("re-lock after a 0.5 rad step on the neck (s from the step to bit-exact pass-through)")
    for rate in (30.0, 100.0, 1000.0):
        print(f"  {rate:6.0f} Hz  {relock_seconds(desk, rate):.2f} s")
    peer = ruckig_us(int(desk.continuous_mask.sum()))
    n_gov = int(SafetyNet(desk, 100.0).idx.size)
    print(f"cost per tick on nutty_desk ({n_gov} governed channels)")
    for kind in ("pass", "correct"):
        us = cost_us(desk, kind)
        ratio = (
            f"  ({us / peer:.2f}x one Ruckig update of {int(desk.continuous_mask.sum())} DoFs: {peer:.1f} us)"
            if peer
            else ""
        )
        print(f"  {kind:8s} {us:6.1f} us{ratio}")
        headline(f"safety net on nutty_desk, {kind}: {us:.1f} µs per tick{ratio.replace('x one', '× one')}")
    joint_stage(desk)


def joint_stage(desk) -> None:
    import tempfile

    from bench_engine import synthetic_urdf

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "many.urdf"
        path.write_text(synthetic_urdf(1000))
        many = load_embodiment(path)
    print("the joint stage's cost per tick (target: <= 20 us on nutty_desk, <= 0.3 ms with 1000 DoFs)")
    for label, emb, n in (("nutty_desk", desk, 20_000), ("1000 DoFs", many, 2_000)):
        governed = len(SafetyNet(emb, 100.0)._jidx)
        for kind in ("pass", "correct"):
            both = min(cost_us(emb, kind, n) for _ in range(3))
            alone = min(cost_us(emb, kind, n, joints=False) for _ in range(3))
            print(
                f"  {label:10s} {kind:8s} channels+joints {both:7.1f} us, channels alone {alone:7.1f} us: "
                f"joint stage {both - alone:6.1f} us ({governed} joints stepped)"
            )


if __name__ == "__main__":
    with recorded("bench_safety", "Safety net: swap jumps, re-lock, cost per tick"):
        main()
