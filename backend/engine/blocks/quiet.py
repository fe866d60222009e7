"""Blocks that can say their next tick would change nothing, so the compiled core skips it.

Most ticks of an event-driven block (a silent voice, an idle clip player, a held posture, a face) hand
out the same frame and change nothing: they wait for a command. A tick woken from a sleep still pays
for each Python call it makes (~3-8 µs on the 2-core VM measured in issue 36), so the compiled core
(backend/engine/core/program.py) skips a quiet block's tick while nothing it reads has changed.

The contract, for a class that mixes in `QuietWhenIdle`: a tick sets `self.quiet` to True only when
another tick with the same wired input values (the same objects), the same `params` and `state`
objects and no command in between would change nothing (no state, no note, no event) and return the
same outputs; else to False. The core checks the inputs, params and state; any `handle` call clears
`quiet` (the mixin wraps each class's own `handle`), so a command always reaches a tick. A block whose
idle ticks count time (a watchdog's timer) must not say it is quiet. A quiet tick may also narrow the
inputs that count (`quiet_reads`): an idle clip player reads only its trigger, so a wired speed that
changes every tick (an emotion's smoothing) does not wake it; the next tick must then change nothing
whatever the other inputs hold.

The blocks' own ticks never skip (the APU's loop without the core, and the timed ticks), so
`tests/test_compiled_core.py`'s agreement of the two paths checks every skip.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

#: `quiet_reads` of a block whose quiet tick reads only its `trigger` input.
TRIGGER_ONLY = frozenset({"trigger"})


def _waking(handle: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(handle)
    def wake_then_handle(self: Any, command: str, args: dict[str, Any]) -> Any:
        self.quiet = False
        return handle(self, command, args)

    return wake_then_handle


class QuietWhenIdle:
    """Mixin (before the block's base class): the `quiet` flag and its clearing on every command."""

    #: Set by `tick`: True when the next tick, on the same inputs, params and state, would change nothing.
    quiet: bool = False
    #: Set by `tick` beside `quiet`: the input ports that next tick reads (None: every one).
    quiet_reads: frozenset[str] | None = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        own = cls.__dict__.get("handle")
        if own is not None:
            setattr(cls, "handle", _waking(own))  # noqa: B010 - assigning a method: type checkers reject `cls.handle =`
