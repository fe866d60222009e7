"""What the clock may reach only now and then, made ready on a thread of its own so no tick pays for it.

A numba function compiled with `cache=True` loads its machine code from disk on its first call with
a given set of argument types: about 10 ms each, which the clock paid on the first frame the safety net
corrected (`frames.net_correction`: 28 ms measured on nutty_desk, 14 lost ticks at 500 Hz). The engine
starts this once per process, at its second tick (the first frame never waits on the loading thread's
claim on the interpreter lock); each warmer calls its functions once on small arrays of the types the
tick passes (the robot's limits are read-only arrays: a signature of their own).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from backend.engine import clock_cpu

log = logging.getLogger(__name__)


class OnceInBackground:
    """`fn` run once, on a daemon thread of its own started by the first `start` (or `wait`): work the
    clock can do without until it is done (the warmers below, a kernel's loading:
    backend/engine/compiled/lazy_entry.py)."""

    def __init__(self, fn: Callable[[], None], name: str):
        self.fn, self.name = fn, name
        self.done = threading.Event()  # set once `fn` returned or raised
        self._started = False
        self._lock = threading.Lock()

    def start(self) -> None:
        with self._lock:
            if self._started:
                return
            self._started = True
        threading.Thread(target=self._run, name=self.name, daemon=True).start()

    def _run(self) -> None:
        clock_cpu.leave()  # started by the clock thread, maybe: not on the clock's own CPU
        try:
            self.fn()
        finally:
            self.done.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Start if need be and wait; whether `fn` has finished."""
        self.start()
        return self.done.wait(timeout)


_WARMERS: list[Callable[[], None]] = []


def warm_later(fn: Callable[[], None]) -> Callable[[], None]:
    """Register `fn` (quick, no arguments) to run on the warm-up thread; returns it (a decorator)."""
    _WARMERS.append(fn)
    return fn


def _run() -> None:
    for fn in list(_WARMERS):
        try:
            fn()
        except Exception:  # a warmer's failure only leaves that code to load on first use
            log.exception("warming %s failed; it loads on first use", getattr(fn, "__qualname__", fn))


_WARM_UP = OnceInBackground(_run, "nutty-warm-up")
#: Run the warmers on a thread of their own, once per process.
start = _WARM_UP.start
#: Start if need be and wait for every warmer; whether they all ran.
wait = _WARM_UP.wait
