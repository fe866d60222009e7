"""The engine's tick hooks: Python called on the clock thread at the start of every tick (a behaviour
player, a ROS 2 trajectory), before the program runs.

A hook with nothing to do may return `IDLE`: it is not called again until `wake` (a woken tick pays
~5 µs for each call it makes, and an idle behaviour player would be called on every tick of a served
robot for nothing). Whoever gives a sleeping hook work wakes it, on the clock thread (inside
`Engine.call`), before the tick that needs it.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from backend.logs import Throttle

log = logging.getLogger(__name__)
_faults = Throttle(every=10.0)  # a faulty hook fails on every tick: logged once per 10 s


class _Idle:
    def __repr__(self) -> str:
        return "IDLE"


#: What a hook returns to sleep until woken.
IDLE: Any = _Idle()

Hook = Callable[[float], Any]


class TickHooks:
    """The hooks in the order they were added; `awake` those not asleep (what a tick calls)."""

    def __init__(self) -> None:
        self.hooks: list[Hook] = []
        self.awake: tuple[Hook, ...] = ()

    def add(self, fn: Hook) -> None:
        self.hooks.append(fn)
        self.awake = (*self.awake, fn)

    def wake(self, fn: Hook) -> None:
        """Call `fn` again from the next tick (clock thread; a hook awake already stays as it is)."""
        if fn not in self.awake:
            self.awake = tuple(h for h in self.hooks if h in self.awake or h == fn)

    def run(self, t: float) -> None:
        """Call every awake hook with `t` (s, the time of the frame the tick makes); a fault is logged
        (throttled) and the tick goes on."""
        for fn in self.awake:
            try:
                if fn(t) is IDLE:
                    self.awake = tuple(h for h in self.awake if h != fn)
            except Exception as exc:  # a hook's fault must not stop the clock
                skipped = _faults.due(f"tick hook {fn!r}: {type(exc).__name__}")
                if skipped is not None:
                    log.error("a tick hook failed", exc_info=exc)
