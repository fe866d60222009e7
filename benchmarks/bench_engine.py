"""What users run, measured: every shipped program headless and inside a real `nutty serve`, at 100,
500 and 1000 Hz, and a 1000-DoF robot running breathe-anything through the mixer and the NMF.

Every figure is also given as a ratio to the peer measured in the same run: one Ruckig streaming
update of 25 DoFs (bench_nmf.py's measurement, best of interleaved rounds), so numbers from a busy
or a fast machine compare.

1. Headless: `engine.tick()` timed one by one while the scripted AI (tests/scripted_ai.py) sends its
   commands; tick p50/p99 per program and rate. The interactive program also on the numpy reference
   path (NUTTY_REFERENCE / `Engine(compiled=False)`) and, with breathe-anything, without the compiled
   program core (NUTTY_CORE=0: each block's own compiled tick, dispatched from Python) for comparison.
   Then the wake pattern (benchmarks/wake.py): the interactive program and 1000-DoF breathe-anything
   against one Ruckig-25 update, both timed back to back (hot) and after each sleep of the tick's
   period (woken: what a real clock finds), interleaved. The `floor` row times one small numpy call
   alike, and the `scattered` row one attribute read of 100 Python objects spread over a large heap:
   on a virtual machine, caches and address translations are cold after a sleep, and a woken tick
   pays for every distinct path it runs and, above all, for every object and array it touches.
2. Served: `nutty serve` with the Pre-Viz on (in its own process) and its page open, 4 editor telemetry clients, a 100 Hz
   driver and the scripted AI over REST (benchmarks/served.py): tick p50/p99 (and the tick's own CPU
   time), lateness p99 (the period jitter: how late a tick starts), overruns, lost ticks, and the
   tick p50 as a ratio to the same program's headless p50. Peer row `alone`: the same program and
   rate on a running clock without a server, measured just before (a clock that sleeps between ticks
   finds colder caches than a tight headless loop, and the machine's other load delays any clock).
   Peer beside (at 100 Hz, the target's rate): Ruckig-25 woken at the clock's period in a process of its
   own during the same window (benchmarks/peer_beside.py), so that it wakes to the same loaded machine
   as the served tick; the target is judged against it (the median ratio of `TARGET_ROUNDS` windows,
   each with its own peer), and the ratio to Ruckig-25 woken on the quiet machine before
   (the wake table) is printed beside. The machine's load average is printed.
   Then the same at 100 Hz with `--clock-cpu auto` (the clock on a CPU of its own, kept out of idle
   states where the benchmark may: root), beside the interactive tick and Ruckig-25 woken alike on
   such a CPU: what a robot's set-up gives, and the ratio when both sides get it.
   With `--long`, 500 Hz for `STEADY_ROUNDS` windows of 60 s (the steadiness target), each beside bare
   real-time sleep loops on every CPU (benchmarks/machine_stalls.py): every overrun of the server
   (/api/status `recent_overruns`) is set against the stalls those loops saw at the same moment, so a
   minute lost to the machine reads apart from one lost to the server.
3. Start-up of `nutty serve` to its first frame, with numba's cache warm (and cold: `--cold`).
4. Where the server's cost comes from (`--long` or `--attribute`): the served figures at 500 Hz with
   no clients, then each part of the load alone (the Pre-Viz and its page, the telemetry clients, the
   driver and the AI), then all of it.

Targets (issue 15; benchmarks, never tests): interactive tick p50 <= 3x a Ruckig update headless and
<= 1.3x its headless cost in the server; 500 Hz in the server for 60 s (`--long`) with no overrun and
lateness p99 <= 0.5 ms; 1000 DoFs <= 1 ms per tick; start-up <= 3 s with warm caches.
Issue 36 tightens them, each against Ruckig-25 in the same run under the same wake pattern, and the
headlines say whether each is met (`TARGETS`): interactive served at 100 Hz <= 3x; headless hot <= 2x;
1000-DoF breathe-anything <= 100 µs hot; 500 Hz served for 60 s with 0 overruns and lateness p99
<= 0.3 ms; start-up <= 2 s warm.

Run: .venv/bin/python benchmarks/bench_engine.py [--seconds 8] [--long] [--cold] [--no-server] [--no-startup]
     (make bench runs it with the defaults, a few minutes; make bench-long adds --long, which also
     measures the cold start)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import contextlib

import machine_stalls
import python_left
import scripted_ai
import wake
from bench_nmf import time_ruckig
from results import headline, recorded

from backend.engine import warm_up
from backend.engine.compiled import REFERENCE_ENV
from backend.engine.core.program import CORE_ENV, KERNEL
from backend.engine.embodiment import load_embodiment
from backend.engine.frame_tail import TAIL
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

PROGRAMS = ROOT / "robots" / "nutty_desk" / "programs"
RATES = (100.0, 500.0, 1000.0)
SCRIPT_SECONDS = scripted_ai.PERIOD  # program time per headless row: the whole script once
WARM_UP = 100  # ticks before the timing starts (first calls)
RUCKIG_DOFS = 25


def synthetic_urdf(n: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l0"/><child link="l{i + 1}"/><axis xyz="0 0 1"/>'
        f'<limit lower="-1" upper="1" velocity="2" effort="1"/></joint>'
        for i in range(n)
    )
    return f'<?xml version="1.0"?><robot name="many{n}">{links}{joints}</robot>'


def three_layer_program() -> dict:
    """A light Level 3 program (three layers and the safety limiter): bench_clock.py's steadiness load."""
    b = ProgramBuilder("bench-l2")
    rest = b.node("rest_pose", "rest")
    breathe = b.node("sine", "breathe", dofs=["*"], amplitude=0.05, frequency=0.3, phase_spread=0.1)
    gesture = b.node("sine", "gesture", dofs=["*"], amplitude=0.4, frequency=1.0)
    gain = b.node("gain_offset", "gain", gain=0.8)
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[
            {"name": "base"},
            {"name": "idle", "mode": "additive"},
            {"name": "gesture", "mode": "override", "weight": 0.7},
        ],
    )
    safety = b.node("safety_limiter", "safety")
    b.connect(rest, mix, "out", "base").connect(breathe, mix, "out", "idle")
    b.chain(gesture, gain)
    b.connect(gain, mix, "out", "gesture")
    b.chain(mix, safety, b.output())
    return b.to_dict()


class Peer:
    """One Ruckig streaming update of 25 DoFs (µs): the best of the rounds measured so far."""

    def __init__(self) -> None:
        self.targets = wake.peer_targets(RUCKIG_DOFS)
        self.us = float("inf")

    def round(self) -> float:
        self.us = min(self.us, time_ruckig(RUCKIG_DOFS, self.targets, 2000))
        return self.us


@contextlib.contextmanager
def switched(compiled: bool = True, core: bool = True):
    """Engines made inside run compiled or on the numpy reference, with or without the compiled core
    (the documented switches: backend.engine.compiled, backend.engine.core.program)."""
    saved = {name: os.environ.get(name) for name in (REFERENCE_ENV, CORE_ENV)}
    os.environ[REFERENCE_ENV] = "0" if compiled else "1"
    os.environ[CORE_ENV] = "1" if core else "0"
    KERNEL.wait()  # the core's kernel from the first tick (it loads on its own thread)
    TAIL.wait()  # the engine's compiled tail, likewise
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def interactive_session(core: bool) -> EngineSession:
    """A session of the interactive program on the bundled robot, with or without the compiled core."""
    with switched(core=core):
        return EngineSession.create(load_embodiment("nutty_desk"), program=program("interactive"))


def headless_costs(
    emb, program: dict, rate: float, compiled: bool = True, seconds: float = SCRIPT_SECONDS, core: bool = True
) -> np.ndarray:
    """µs of each `engine.tick()` of `program` at `rate` over `seconds` of program time under the
    scripted AI (after a few warm-up ticks)."""
    with switched(compiled, core):
        session = settled_session(emb, rate, program)
    engine = session.engine
    ticks = round(seconds * rate) + WARM_UP
    script = list(scripted_ai.timeline(ticks / rate))
    costs = np.empty(ticks)
    k = 0
    for i in range(ticks):
        while k < len(script) and script[k][0] <= engine.t + 1e-9:
            with contextlib.suppress(ValueError):  # a program without the command's target
                session.execute(script[k][1])
            k += 1
        t0 = time.perf_counter()
        engine.tick()
        costs[i] = time.perf_counter() - t0
    engine.close()
    return costs[WARM_UP:] * 1e6


def settled_session(emb, rate: float, prog: dict) -> EngineSession:
    """A session whose start-up threads are done (its sounds read, the clock's rare code loaded):
    the figures are the steady state's, not a start-up's contention for the interpreter lock."""
    session = EngineSession.create(emb, rate=rate, program=prog)
    if session.library.sounds.warming is not None:
        session.library.sounds.warming.join()
    warm_up.wait()
    return session


def program(name: str) -> dict:
    return json.loads((PROGRAMS / f"{name}.json").read_text())


def fmt_ratio(us: float, peer: float) -> str:
    return f"{us:9.1f} {us / peer:6.2f}x"


def run_headless(peer: Peer) -> dict[str, float]:
    """Print the headless table; returns the interactive program's p50 per rate (µs)."""
    desk = load_embodiment("nutty_desk")
    names = sorted(p.stem for p in PROGRAMS.glob("*.json"))
    rows: list[tuple[str, float, np.ndarray]] = []
    for name in names:
        for rate in RATES:
            peer.round()
            rows.append((name, rate, headless_costs(desk, program(name), rate)))
    peer.round()
    rows.append(
        ("interactive (numpy reference)", 100.0, headless_costs(desk, program("interactive"), 100.0, False))
    )
    for name in ("interactive", "breathe-anything"):
        peer.round()
        rows.append((f"{name} (core off)", 100.0, headless_costs(desk, program(name), 100.0, core=False)))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "many.urdf"
        path.write_text(synthetic_urdf(1000))
        many = load_embodiment(path)
    for rate in (100.0, 1000.0):
        peer.round()
        rows.append(
            (
                f"breathe-anything, {many.n_channels} DoFs",
                rate,
                headless_costs(many, program("breathe-anything"), rate, seconds=1000 / rate),
            )
        )
    us = peer.round()
    print(
        f"\nPeer: one Ruckig streaming update of {RUCKIG_DOFS} DoFs = {us:.1f} µs (best of {len(rows) + 1} "
        f"rounds interleaved with the rows below)"
    )
    print("\nHeadless: engine.tick() under the scripted AI, timed tick by tick")
    print(f"{'program':<34} {'rate':>6} {'tick p50 µs':>11} {'xRuckig':>7} {'p99 µs':>9} {'xRuckig':>7}")
    for name, rate, costs in rows:
        p50, p99 = np.percentile(costs, [50, 99])
        print(f"{name:<34} {rate:>6g} {fmt_ratio(p50, us)}  {fmt_ratio(p99, us)}")
    for name, rate, costs in rows:
        if (name, rate) in (
            ("interactive", 100.0),
            ("interactive (numpy reference)", 100.0),
            ("interactive (core off)", 100.0),
        ) or (name.endswith("DoFs") and rate == 100.0):
            p50 = float(np.percentile(costs, 50))
            headline(
                f"headless {name} at 100 Hz under the scripted AI: tick {p50:.0f} µs p50 = {p50 / us:.2f}× "
                f"one Ruckig-25 update ({us:.1f} µs)"
            )
    return {rate: float(np.percentile(c, 50)) for name, rate, c in rows if name == "interactive"}


#: The clock rate (Hz) of the served target.
SERVED_TARGET_RATE = 100.0
#: Served windows at the target's rate, each with its own peer beside: the verdict takes the median of
#: their ratios, as the host's moment moves both sides by up to 2x from one window to the next.
TARGET_ROUNDS = 3
#: Issue 36's targets: interactive served at 100 Hz over Ruckig-25 woken beside it in the same window;
#: interactive hot over Ruckig-25 hot; 1000-DoF breathe-anything hot (µs); start-up with warm caches (s);
#: lateness p99 (ms) of 60 s served at 500 Hz, with no overrun (`--long`).
#: 60 s windows of the 500 Hz steadiness run: whether a minute passes without an overrun is a matter of
#: chance on a shared machine (a stall of a few ms now and then), so one window says little.
STEADY_ROUNDS = 3
TARGETS = {"served": 3.0, "hot": 2.0, "many_us": 100.0, "startup_s": 2.0, "steady_late_ms": 0.3}


def verdict(value: float, target: float, unit: str) -> str:
    """`target <= 2×: misses` (unit: "×", " µs", " s")."""
    return f"target <= {target:g}{unit}: {'meets' if value <= target else 'misses'}"


#: (label, sleep s, the clock rate it stands for: None for back to back)
WAKE_PATTERNS = (
    ("hot", 0.0, None),
    ("woken at 1000 Hz", 0.001, 1000.0),
    ("woken at 500 Hz", 0.002, 500.0),
    ("woken at 100 Hz", 0.01, 100.0),
)


#: The wake table's row that times one small numpy call: what this machine charges any code for waking.
FLOOR = "floor: one numpy call"
#: Its row that reads one attribute of 100 Python objects spread over a large heap: what waking charges
#: per object a tick touches (the Python parts of a tick touch hundreds).
SCATTERED = "100 scattered Python objects"


def run_wake(peer: Peer) -> dict[float, float]:
    """The interactive program and 1000-DoF breathe-anything against Ruckig-25, hot and woken
    (benchmarks/wake.py). Returns Ruckig-25's woken p50 (µs) by the clock rate it stands for."""
    desk = load_embodiment("nutty_desk")
    with switched(core=False):
        no_core = settled_session(desk, 100.0, program("interactive")).engine
    with switched():
        engines = [settled_session(desk, 100.0, program("interactive")).engine]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "many.urdf"
        path.write_text(synthetic_urdf(1000))
        many = load_embodiment(path)
    with switched():
        engines.append(settled_session(many, 100.0, program("breathe-anything")).engine)
    engines.append(no_core)
    for engine in engines:
        engine.run_ticks(WARM_UP)
    floor = np.empty(22)
    spread, _heap = wake.scattered_objects(100)
    ticks = {
        "interactive": lambda k: engines[0].tick(),
        "interactive (core off)": lambda k: engines[2].tick(),
        f"breathe-anything, {many.n_channels} DoFs": lambda k: engines[1].tick(),
        # The machine's own charge for waking: one small numpy call, the least a tick can do.
        FLOOR: lambda k: np.copyto(floor, 0.0),
        SCATTERED: lambda k: wake.read_all(spread),
    }
    patterns = tuple((label, sleep) for label, sleep, _ in WAKE_PATTERNS)
    rows = wake.wake_rows(ticks, wake.ruckig_step(RUCKIG_DOFS, peer.targets, 0.01), patterns)
    for engine in engines:
        engine.close()
    wake.print_wake(rows, RUCKIG_DOFS)
    woken: dict[float, float] = {}
    rates = {label: rate for label, _, rate in WAKE_PATTERNS}
    for name, label, a, b in rows:
        a50, b50 = float(np.percentile(a, 50)), float(np.percentile(b, 50))
        if name == "interactive" and rates[label] is not None:
            woken[rates[label]] = b50
        if label in ("hot", "woken at 100 Hz"):
            goal = ""
            if label == "hot" and not name.endswith("(core off)") and name not in (FLOOR, SCATTERED):
                many = name != "interactive"
                goal = (
                    f" ({verdict(a50, TARGETS['many_us'], ' µs')})"
                    if many
                    else f" ({verdict(a50 / b50, TARGETS['hot'], '×')})"
                )
            headline(
                f"{name}, {label}: tick {a50:.0f} µs p50 against Ruckig-25 {b50:.0f} µs timed alike = "
                f"{a50 / b50:.2f}×{goal}"
            )
    return woken


def clock_alone(rate: float, seconds: float) -> dict:
    """The same program on a running clock in this process, without a server (the AI's commands sent
    every 0.5 s from this thread): what the clock gets from this machine. Its /api/status figures."""
    session = settled_session(load_embodiment("nutty_desk"), rate, program("interactive"))
    engine = session.engine
    engine.start()
    script = list(scripted_ai.timeline(1e6))
    time.sleep(1.0)
    engine.call(engine.reset_stats)
    ticks, overruns, lost = engine.ticks, engine.overruns, engine.lost_ticks
    end, k = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        with contextlib.suppress(ValueError):
            session.execute(script[k][1])
        k += 1
        time.sleep(0.5)
    stats = engine.stats()
    engine.close()
    stats.update(
        ticks=engine.ticks - ticks, overruns=engine.overruns - overruns, lost_ticks=engine.lost_ticks - lost
    )
    return stats


def run_served(
    peer: Peer,
    seconds: float,
    rates: tuple[float, ...],
    headless: dict[float, float],
    woken: dict[float, float] | None = None,
    stalls: bool = False,
) -> list[dict]:
    """The served table; `woken`: Ruckig-25's p50 (µs) woken at each rate (run_wake), the served
    tick's peer under the same wake pattern. `stalls`: also watch the machine's own stalls in each
    window (benchmarks/machine_stalls.py) and say which overruns fell in one."""
    import served

    results = []
    for rate in rates:
        peer.round()
        alone = clock_alone(rate, min(seconds, 8.0))
        load = os.getloadavg()[0]
        # The peer beside only where the ratio is a target (100 Hz): at 500 Hz it would share the CPUs with
        # the steadiness target's clock for a whole minute.
        r = served.measure(rate, seconds, peer_beside=rate == SERVED_TARGET_RATE, stalls_beside=stalls)
        r.update(load=load, alone=alone)
        if rate == SERVED_TARGET_RATE:
            again = [served.measure(rate, seconds, peer_beside=True) for _ in range(TARGET_ROUNDS - 1)]
            r["rounds"] = [_tick_and_peer(x) for x in (r, *again)]
        elif stalls:
            again = [served.measure(rate, seconds, stalls_beside=True) for _ in range(STEADY_ROUNDS - 1)]
            r["steady_rounds"] = [r, *again]
        results.append(r)
    us = peer.round()
    print(
        f"\nServed: nutty serve, interactive program, Pre-Viz on (its own process) with its page open, {served.TELEMETRY_CLIENTS} "
        f"telemetry clients at {served.TELEMETRY_HZ} Hz, a {served.DRIVER_HZ} Hz driver, the scripted AI over "
        f"REST every {served.AI_PERIOD:g} s (Ruckig peer {us:.1f} µs)"
    )
    print(
        "(`alone`: the same program and rate on a clock in the benchmark's process with no server, just before; "
        "`/headless` and `/alone`: the served tick p50 over the headless p50 and over the alone p50)"
    )
    print(
        f"{'rate':>5} {'run':>7} {'window':>7} {'load':>5} {'tick p50 µs':>11} {'xRuckig':>7} {'p99 µs':>9} "
        f"{'xRuckig':>7} {'cpu p50':>8} {'/headless':>9} {'/alone':>7} {'late p99 ms':>11} {'overruns':>8} {'lost':>6}"
    )
    for r in results:
        for label, st in (("alone", r["alone"]), ("served", r["status"])):
            counts = r["alone"] if label == "alone" else r
            p50, p99 = st["tick_cost"]["p50_ms"] * 1e3, st["tick_cost"]["p99_ms"] * 1e3
            base, alone = headless.get(r["rate"]), r["alone"]["tick_cost"]["p50_ms"] * 1e3
            vs = f"{p50 / base:8.2f}x" if base else f"{'-':>9}"
            window = f"{r['seconds']:>6.1f}s" if label == "served" else f"{'':>7}"
            load = f"{r['load']:>5.1f}" if label == "served" else f"{'':>5}"
            print(
                f"{r['rate']:>5g} {label:>7} {window} {load} {fmt_ratio(p50, us)}  {fmt_ratio(p99, us)} "
                f"{st['tick_cpu']['p50_ms'] * 1e3:>8.1f} {vs} {p50 / alone:>6.2f}x {st['jitter']['p99_ms']:>11.3f} "
                f"{counts['overruns']:>8} {counts['lost_ticks']:>6}"
            )
    for r in results:
        b = r["peer_beside"]
        if b is None:
            continue
        print(
            f"  {r['rate']:g} Hz Ruckig-25 woken beside the server in the same window (its own process, "
            f"{'real-time priority' if b['realtime'] else 'normal priority'}): {b['p50_us']:.1f} µs p50, "
            f"{b['p99_us']:.1f} µs p99, {b['updates']} updates"
        )
    for r in results:
        for k, x in enumerate(r.get("steady_rounds", [r] if r["machine_stalls"] is not None else [])):
            print(f"  window {k + 1}:\n{_stalls_line(x)}")
    for r in results:
        c = r["counts"]
        print(
            f"  {r['rate']:g} Hz load delivered: {c['telemetry']} telemetry messages, {c['frames']} driver frames, "
            f"{c['previz']} Pre-Viz messages ({c['previz_reconnects']} reconnects), {c['commands']} commands"
        )
    for r in results:
        st = r["status"]
        late = st["jitter"]["p99_ms"]
        steady = ""
        if r["rate"] == 500.0 and r["seconds"] >= 60.0:
            steady = _steady_verdict(r.get("steady_rounds", [r]))
        headline(
            f"served at {r['rate']:g} Hz for {r['seconds']:.0f} s (Pre-Viz, 4 telemetry clients, a driver, the "
            f"AI): tick {st['tick_cost']['p50_ms'] * 1e3:.0f} µs p50 (CPU {st['tick_cpu']['p50_ms'] * 1e3:.0f} µs) "
            f"= {_vs_woken(st['tick_cost']['p50_ms'] * 1e3, r['rate'], r, woken, us)}; lateness p99 "
            f"{late:.2f} ms; " + (steady or f"{r['overruns']} overruns")
        )
    top = sorted(results[0]["profile"]["nodes"], key=lambda n: -n["mean_us"])[:6]
    print(
        "  most expensive nodes in the server (mean µs): "
        + ", ".join(f"{n['node']} ({n['type']}) {n['mean_us']:.0f}" for n in top)
    )
    return results


def _machine_overruns(r: dict[str, Any]) -> int:
    """How many of the window's server overruns fell in a stall of a CPU (benchmarks/machine_stalls.py)."""
    stalls = r["machine_stalls"]["stalls"] if r["machine_stalls"] else []
    return sum(machine_stalls.coincides(o, stalls) for o in r["window_overruns"])


def _steady_verdict(rounds: list[dict[str, Any]]) -> str:
    """Each 60 s window of the 500 Hz run (its overruns, how many fell in a stall of a CPU, its lateness
    p99), then `(target …: meets|misses|meets in k of n windows)`."""
    late_ok = TARGETS["steady_late_ms"]
    met = [x["overruns"] == 0 and x["status"]["jitter"]["p99_ms"] <= late_ok for x in rounds]
    each = "; ".join(
        f"{x['overruns']} overrun{'' if x['overruns'] == 1 else 's'}{_overruns_split(x)} "
        f"(lateness p99 {x['status']['jitter']['p99_ms']:.2f} ms)"
        for x in rounds
    )
    verdict = (
        "meets" if all(met) else "misses" if not any(met) else f"meets in {sum(met)} of {len(met)} windows"
    )
    return f"per 60 s window: {each} (target 0 overruns, lateness p99 <= {late_ok:g} ms: {verdict})"


def _overruns_split(r: dict[str, Any]) -> str:
    """`, N in stalls of a CPU …, M the server's own` for a window watched for stalls."""
    if r["machine_stalls"] is None or not r["overruns"]:
        return ""
    shared = _machine_overruns(r)
    own = r["overruns"] - shared  # overruns beyond the recorded 32 count as the server's own
    return f", {shared} in stalls of a CPU that a bare sleep loop beside it saw too, {own} the server's own"


def _stalls_line(r: dict[str, Any]) -> str:
    """The machine's stalls beside a served window, and the server's overruns set against them."""
    m = r["machine_stalls"]
    each = ", ".join(
        f"woke {o['late_ms']:.1f} ms late, ran {o['tick_ms']:.2f} ms" for o in r["window_overruns"]
    )
    return (
        f"  {r['rate']:g} Hz the machine's own stalls in the same window (a bare sleep loop on each of CPUs "
        f"{m['cpus']}, {'real-time priority' if m['realtime'] else 'normal priority'}): lateness p99 "
        f"{m['late_p99_ms']:.3f} ms, max {m['late_max_ms']:.2f} ms, {len(m['stalls'])} wakes later than a period, "
        f"{m['overruns']} overruns\n  {r['rate']:g} Hz the server's overruns in the window: {r['overruns']}"
        + (f" ({each}); {_machine_overruns(r)} of them while the machine stalled" if each else "")
    )


def _tick_and_peer(r: dict[str, Any]) -> tuple[float, float]:
    """(served tick p50, Ruckig-25 beside it p50) of one served window, µs."""
    return r["status"]["tick_cost"]["p50_ms"] * 1e3, r["peer_beside"]["p50_us"]


def _vs_woken(
    tick_us: float, rate: float, served_run: dict[str, Any], woken: dict[float, float] | None, hot: float
) -> str:
    """The served tick over Ruckig-25 woken at the same rate beside the server in the same window (the
    target's measure: the same run, wake pattern and load; at the target's rate the median over
    `TARGET_ROUNDS` windows), and over Ruckig-25 woken on the quiet machine before (the wake table);
    over the hot update when neither was measured."""
    parts = []
    beside, rounds = served_run.get("peer_beside"), served_run.get("rounds")
    if rounds:
        ratios = [t / p for t, p in rounds]
        ratio = float(np.median(ratios))
        each = ", ".join(f"{x:.2f}×" for x in ratios)
        parts.append(
            f"{ratio:.2f}× Ruckig-25 woken beside it (median of {len(ratios)} windows: {each}; this one's "
            f"peer {beside['p50_us']:.0f} µs, {verdict(ratio, TARGETS['served'], '×')})"
        )
    elif beside:
        parts.append(
            f"{tick_us / beside['p50_us']:.2f}× Ruckig-25 woken beside it ({beside['p50_us']:.0f} µs)"
        )
    if woken and rate in woken:
        parts.append(
            f"{tick_us / woken[rate]:.2f}× Ruckig-25 woken on the quiet machine ({woken[rate]:.0f} µs)"
        )
    return ", ".join(parts) if parts else f"{tick_us / hot:.2f}× Ruckig-25 hot"


def run_clock_cpu(peer: Peer, seconds: float, woken: dict[float, float] | None) -> None:
    """`nutty serve --clock-cpu auto` at 100 Hz under the served load, and the interactive tick against
    Ruckig-25 woken alike on a CPU of their own kept awake the same way (wake.side_by_side_on_own_cpu):
    what the clock's own CPU gives, and the ratio when both sides get it."""
    import served

    with switched():
        engine = settled_session(load_embodiment("nutty_desk"), 100.0, program("interactive")).engine
    engine.run_ticks(WARM_UP)
    both = wake.side_by_side_on_own_cpu(
        lambda k: engine.tick(), wake.ruckig_step(RUCKIG_DOFS, peer.targets, 0.01), 0.01
    )
    engine.close()
    if both is None:
        print("\n--clock-cpu: this machine lets the process use one CPU only; not measured")
        return
    a50, b50 = float(np.median(both[0])), float(np.median(both[1]))
    own = both[2]
    awake = "kept awake" if own["kept_awake"] else f"not kept awake: {own['note']}"
    r = served.measure(100.0, seconds, server_args=("--clock-cpu", "auto"))
    st = r["status"]
    cpu = st.get("clock_cpu") or {}
    p50 = st["tick_cost"]["p50_ms"] * 1e3
    print(
        f"\nThe clock on a CPU of its own (--clock-cpu auto: CPU {own['cpu']}, {awake}), woken at 100 Hz: "
        f"interactive tick {a50:.0f} µs p50 against Ruckig-25 {b50:.0f} µs on the same CPU = {a50 / b50:.2f}×"
    )
    print(
        f"  served at 100 Hz with --clock-cpu auto (server's clock_cpu: {cpu}): tick {p50:.0f} µs p50 "
        f"(CPU {st['tick_cpu']['p50_ms'] * 1e3:.0f} µs), p99 {st['tick_cost']['p99_ms'] * 1e3:.0f} µs, "
        f"lateness p99 {st['jitter']['p99_ms']:.2f} ms, {r['overruns']} overruns"
    )
    plain = f"{p50 / woken[100.0]:.2f}× Ruckig-25 woken plainly ({woken[100.0]:.0f} µs), " if woken else ""
    headline(
        f"served at 100 Hz with --clock-cpu ({awake}): tick {p50:.0f} µs p50 = {plain}"
        f"{p50 / b50:.2f}× Ruckig-25 woken on a CPU kept awake alike ({b50:.0f} µs); not the target's "
        "measure (that is the served line above, on the default set-up)"
    )


#: Where the server's extra cost comes from: the same server under one part of the load at a time.
ATTRIBUTION = (
    ("server, no clients", (), ("--no-previz",)),
    ("+ Pre-Viz (its own process) and its page", ("previz",), ()),
    ("+ 4 telemetry clients", ("telemetry",), ("--no-previz",)),
    ("+ the driver and the AI", ("driver", "ai"), ("--no-previz",)),
    ("everything", ("telemetry", "previz", "driver", "ai"), ()),
)


def run_attribution(peer: Peer, rate: float, seconds: float, headless: dict[float, float]) -> None:
    """The served figures with each part of the load alone (and none, and all): where the server's
    extra cost over the headless tick comes from."""
    import served

    rows = []
    for label, clients, server_args in ATTRIBUTION:
        peer.round()
        rows.append((label, served.measure(rate, seconds, clients=clients, server_args=server_args)))
    us = peer.round()
    base = headless.get(rate)
    print(
        f"\nWhere the server's cost comes from: nutty serve at {rate:g} Hz under one part of the load at a time "
        f"({seconds:g} s each; Ruckig peer {us:.1f} µs)"
    )
    print(
        f"{'load':<42} {'tick p50 µs':>11} {'xRuckig':>7} {'cpu p50':>8} {'/headless':>9} {'p99 µs':>8} "
        f"{'late p99 ms':>11} {'overruns':>8}"
    )
    for label, r in rows:
        st = r["status"]
        p50, p99 = st["tick_cost"]["p50_ms"] * 1e3, st["tick_cost"]["p99_ms"] * 1e3
        vs = f"{p50 / base:8.2f}x" if base else f"{'-':>9}"
        print(
            f"{label:<42} {fmt_ratio(p50, us)} {st['tick_cpu']['p50_ms'] * 1e3:>8.1f} {vs} {p99:>8.0f} "
            f"{st['jitter']['p99_ms']:>11.3f} {r['overruns']:>8}"
        )


def run_startup(cold: bool) -> None:
    import served

    # The served runs' processes wind down for a few seconds after them; a start then shares the CPU.
    time.sleep(5.0)
    warm = min(served.startup(None) for _ in range(4))  # numba's own cache, filled by the runs above
    line = (
        f"\nStart-up of nutty serve to its first frame (Pre-Viz on): warm caches {warm:.2f} s "
        f"(target <= 3 s: {'meets' if warm <= 3 else 'MISSES'})"
    )
    if cold:
        with (
            tempfile.TemporaryDirectory() as tmp
        ):  # an empty cache: every kernel compiles, as on a fresh clone
            line += f", cold numba cache {served.startup(tmp):.2f} s"
    print(line)
    headline(
        f"`nutty serve` to its first frame, warm caches: {warm:.2f} s ({verdict(warm, TARGETS['startup_s'], ' s')})"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=8.0, help="measurement window of each served run (s)")
    ap.add_argument(
        "--long", action="store_true", help="also serve at 500 Hz for 60 s (the steadiness target)"
    )
    ap.add_argument(
        "--attribute",
        action="store_true",
        help="also serve at 500 Hz under each part of the load alone (where the server's cost comes from)",
    )
    ap.add_argument("--no-server", action="store_true", help="headless figures only")
    ap.add_argument("--no-startup", action="store_true", help="skip the start-up measurement")
    ap.add_argument(
        "--cold",
        action="store_true",
        help="also start with an empty numba cache (compiles every kernel: a minute or two)",
    )
    args = ap.parse_args()
    peer = Peer()
    headless = run_headless(peer)
    woken = run_wake(peer)
    left = python_left.report(interactive_session)
    headline(
        f"Python left in a steady interactive tick under the scripted AI: {left['python_calls']:.1f} calls "
        f"(the blocks' own ticks: {left['core_off_python_calls']:.1f}); the route to the served target "
        "removes them"
    )
    if not args.no_server:
        run_served(peer, args.seconds, RATES, headless, woken)
        run_clock_cpu(peer, args.seconds, woken)
        if args.long:
            run_served(peer, 60.0, (500.0,), headless, woken, stalls=True)
        if args.long or args.attribute:
            run_attribution(peer, 500.0, args.seconds, headless)
    if not args.no_startup:
        run_startup(args.cold or args.long)


if __name__ == "__main__":
    with recorded("bench_engine", "Engine: programs headless and served, 1000 DoFs, start-up"):
        main()
