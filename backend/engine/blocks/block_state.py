"""What the compiled core must look at when a block changes, counted; and a state adopted in a swap.

The compiled core (backend/engine/core/program.py) lists arrays of the blocks' parameters and states
by address, and keeps in its scalars what a block's commands set (an LED's colour, a gaze's look_at in
progress). So it must look at its ops again whenever a block holds another parameters or state object
(an edit, a reset, a swap's adoption) or has handled a command. Looking at every block on every tick
costs a woken tick ~15 µs on a virtual machine (each block is an object the tick would not touch
otherwise); reading one count costs nothing. So both attributes are properties whose setter counts in
`CHANGES` (a read is a C call, `attrgetter` of the private attribute, with no Python frame), and every
block class's own `handle` counts there too: both are rare, and never on a steady tick.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from collections.abc import Callable
from operator import attrgetter
from typing import Any

import numpy as np

#: Assignments of any block's `params` or `state`, and commands handled by any block, so far in this
#: process (one cell, read in place).
CHANGES = [0]


def counted(name: str) -> property:
    """The block attribute `name`, kept at `_name` (the class's `_name` is its default), whose every
    assignment counts in `CHANGES`."""
    private = "_" + name

    def put(block: Any, value: Any) -> None:
        block.__dict__[private] = value
        CHANGES[0] += 1

    return property(attrgetter(private), put, doc=f"The block's {name} (its replacements are counted).")


def counting(handle: Callable[..., Any]) -> Callable[..., Any]:
    """A block class's own `handle`, counting each command in `CHANGES` (before it runs: a command
    that fails half-way may have changed something too)."""

    @functools.wraps(handle)
    def count_then_handle(block: Any, command: str, args: dict[str, Any]) -> Any:
        CHANGES[0] += 1
        return handle(block, command, args)

    return count_then_handle


def state_fits(fresh: Any, old: Any) -> bool:
    """Whether `old` state can replace `fresh`: the same class, and every array of `fresh` matched by an
    array of the same shape (parameters may have changed the DoF set or a buffer's length)."""
    if type(old) is not type(fresh):
        return False
    for f in dataclasses.fields(fresh):
        mine = getattr(fresh, f.name)
        if isinstance(mine, np.ndarray):
            theirs = getattr(old, f.name)
            if not isinstance(theirs, np.ndarray) or theirs.shape != mine.shape:
                return False
    return True


def copy_state(state: Any) -> Any:
    """A copy of a state object whose arrays are copied too (other values are shared)."""
    out = copy.copy(state)
    for f in dataclasses.fields(state):
        value = getattr(state, f.name)
        if isinstance(value, np.ndarray):
            setattr(out, f.name, value.copy())
    return out
