"""The measurements behind design choices the code's docstrings give as reasons (the code keeps the
reason; the figures are here, measured on this machine, each against the alternative it was chosen
over: the peer).

1. Telemetry encoding (backend/safe_json.py): `safe_json.dumps` (orjson) against the standard
   library's `json.dumps` on a telemetry message of the bundled interactive program (the frame, its
   signals and layers): µs per message and the ratio. The event loop holds the interpreter lock, which
   the engine's clock waits for, while it encodes.
2. A sink's wake-up (backend/engine/sinks.py): `Lock.release()` on a lock already released, the
   RuntimeError caught by try/except against `contextlib.suppress`: ns per call and the ratio (it runs
   on the clock's thread for every frame and sink, and the exception is the common case).
3. A playing clip (backend/engine/compiled/curves.py): evaluating every curve of a clip of Bezier keys
   (nutty_desk's 22 channels, 8 keys each) at one time, the compiled kernel against the numpy
   reference (`CurveSet.evaluate_reference`): µs per tick and the ratio.
4. The garbage collector (backend/engine/gil.py): one full collection with the server's modules
   imported and a session loaded after `settle_heap()` froze what was alive, against the same heap
   unfrozen (every object walked): ms per collection and the ratio.

Run: .venv/bin/python benchmarks/bench_design.py  (about half a minute)
"""

from __future__ import annotations

import contextlib
import gc
import json
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from results import headline, recorded

from backend.engine.embodiment import load_embodiment
from backend.session import EngineSession

PROGRAMS = ROOT / "robots" / "nutty_desk" / "programs"


def best_us(fn, number: int, rounds: int = 7) -> float:
    """Best of `rounds` mean µs per call of `fn` over `number` calls (the machine is shared)."""
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best * 1e6


def telemetry_encoding() -> None:
    from backend.routes.telemetry import frame_json, signals_json
    from backend.safe_json import dumps

    desk = load_embodiment("nutty_desk")
    program = json.loads((PROGRAMS / "interactive.json").read_text())
    session = EngineSession.create(desk, rate=100.0, program=program)
    engine = session.engine
    frame = engine.run_ticks(50)[-1]
    apu = engine.apu
    wired = [
        (s.node_id, port) for s in apu.steps for port in s.block.ports(s.block.params)[1] if port != "out"
    ]
    values = [apu.signal_value(node, port) for node, port in wired]
    msg = {"type": "telemetry", "t": frame.t, "seq": frame.seq, "frame": frame_json(desk, frame)}
    msg["signals"] = dict(zip([f"{n}.{p}" for n, p in wired], signals_json(desk, values)))
    msg["layers"] = {s.node_id: s.block.layer_states() for s in apu.steps if hasattr(s.block, "layer_states")}
    text = dumps(msg)

    def stdlib() -> str:
        return json.dumps(msg, ensure_ascii=False, allow_nan=False, separators=(",", ":"))

    fast, slow = best_us(lambda: dumps(msg), 2000), best_us(stdlib, 2000)
    print(
        f"1. telemetry message of the interactive program ({len(text)} characters, {len(msg['signals'])} signals)"
    )
    print(
        f"   safe_json.dumps (orjson) {fast:8.1f} µs   peer json.dumps {slow:8.1f} µs   stdlib/orjson {slow / fast:5.1f}x"
    )


def sink_wake() -> None:
    lock = threading.Lock()  # released: every release raises, as for a sink already signalled

    def try_except() -> None:
        try:  # noqa: SIM105  (the form measured)
            lock.release()
        except RuntimeError:
            pass

    def suppress() -> None:
        with contextlib.suppress(RuntimeError):
            lock.release()

    a, b = best_us(try_except, 200_000) * 1e3, best_us(suppress, 200_000) * 1e3
    print("2. a sink's wake-up when it is already signalled (Lock.release() raising RuntimeError)")
    print(f"   try/except {a:8.0f} ns   peer contextlib.suppress {b:8.0f} ns   suppress/try {b / a:5.1f}x")


def clip_evaluation() -> None:
    from backend.engine.curves import CurveSet, Key

    rng = np.random.default_rng(0)
    curves = [
        [Key(t=float(t), v=float(v)) for t, v in zip(np.arange(8) * 0.5, rng.uniform(-1, 1, 8))]
        for _ in range(22)
    ]
    cs = CurveSet(curves)
    times = iter(np.tile(np.linspace(0.0, 3.5, 997), 10_000))
    cs.evaluate(0.1)  # compile (or load from numba's cache) before timing
    compiled = best_us(lambda: cs.evaluate(next(times)), 2000)
    reference = best_us(lambda: cs.evaluate_reference(next(times)), 500)
    print("3. a playing clip: 22 Bezier curves of 8 keys evaluated at one time (one tick)")
    print(
        f"   compiled {compiled:8.1f} µs   peer numpy reference {reference:8.1f} µs   "
        f"reference/compiled {reference / compiled:5.1f}x"
    )


def garbage_collector() -> None:
    import backend.api  # noqa: F401  (FastAPI, pydantic, numba and the blocks: what the server holds)
    from backend.engine.gil import settle_heap

    settle_heap()  # what the server does once loaded
    desk = load_embodiment("nutty_desk")
    program = json.loads((PROGRAMS / "interactive.json").read_text())
    session = EngineSession.create(desk, rate=100.0, program=program)  # made after: still walked
    session.engine.run_ticks(100)
    t0 = time.perf_counter()
    gc.collect()
    frozen = (time.perf_counter() - t0) * 1e3
    tracked = len(gc.get_objects()) + gc.get_freeze_count()
    gc.unfreeze()  # the same heap, every object walked again
    t0 = time.perf_counter()
    gc.collect()
    walked = (time.perf_counter() - t0) * 1e3
    print(
        f"4. one full garbage collection with the server's modules imported and a session loaded "
        f"({tracked} tracked objects)"
    )
    print(
        f"   after settle_heap() {frozen:8.2f} ms   peer without it {walked:8.2f} ms   "
        f"without/with {walked / frozen:5.1f}x"
    )
    headline(
        f"a full garbage collection with the server loaded: {frozen:.2f} ms after settle_heap(), {walked:.0f} ms without"
    )


def main() -> None:
    telemetry_encoding()
    sink_wake()
    clip_evaluation()
    garbage_collector()


if __name__ == "__main__":
    with recorded("bench_design", "Design choices: the figures behind the code's reasons"):
        main()
