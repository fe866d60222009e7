"""How much Python a steady tick still runs: the interactive program headless under the scripted AI,
with every Python function call and every call into C counted per tick (`sys.setprofile`).

Issue 36's served target needs a tick whose steady state runs no Python (a woken tick pays for every
object it touches): this count is how each step towards that is judged, and unlike a time it does not
move with the host's moment. The same count with the core off (every block's own tick) is printed
beside it, as the peer."""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import scripted_ai

from backend.engine import warm_up

SECONDS = 30.0  # of engine time at 100 Hz: several of the scripted AI's emotions, gestures and looks


def count(session: Any, seconds: float = SECONDS) -> tuple[float, float, list[tuple[str, float]]]:
    """Python calls and C calls per tick of `session` (the interactive program, not yet ticked), and the
    Python functions called most (per tick)."""
    engine = session.engine
    engine.apu.cook.every = 10**9  # the steady path only: no tick timed block by block
    engine.run_ticks(50)
    warm_up.wait(120)  # what a served clock loads beside it from its first tick (the net's report)
    calls: Counter[str] = Counter()

    def profile(frame: Any, event: str, arg: Any) -> None:
        if event == "call":
            code = frame.f_code
            calls[f"{Path(code.co_filename).name}:{code.co_name}"] += 1
        elif event == "c_call":
            calls["<C>"] += 1

    tick = engine.tick

    def counted() -> Any:
        sys.setprofile(profile)
        try:
            return tick()
        finally:
            sys.setprofile(None)

    engine.tick = counted  # type: ignore[method-assign]  # measuring: the session is thrown away after
    ticks = sum(1 for _ in scripted_ai.run(session, seconds))
    engine.close()
    c_calls = calls.pop("<C>", 0) / ticks
    py = sum(calls.values()) / ticks
    return py, c_calls, [(name, n / ticks) for name, n in calls.most_common(8)]


def report(session_on: Callable[[bool], Any]) -> dict[str, float]:
    """Print the counts on the session `session_on(core)` makes, core on and off; returns them."""
    py, c_calls, top = count(session_on(True))
    off_py, off_c, _ = count(session_on(False))
    print(
        f"\nPython left in a steady tick (interactive, headless, scripted AI, {SECONDS:g} s at 100 Hz): "
        f"{py:.1f} Python calls and {c_calls:.1f} C calls per tick; with the core off (the blocks' own "
        f"ticks) {off_py:.1f} and {off_c:.1f}"
    )
    print("  most called: " + ", ".join(f"{name} {n:.2f}" for name, n in top))
    return {"python_calls": py, "c_calls": c_calls, "core_off_python_calls": off_py}
