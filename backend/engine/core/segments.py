"""The compiled core's plan entries besides Python steps (backend/engine/core/program.py): segments of
ops run in one kernel call, the imports that copy Python frames into them, and the memos by which a
quiet Python block sleeps."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.blocks.block_state import CHANGES
from backend.engine.core.ops import Op
from backend.engine.frames import PartialFrame

if TYPE_CHECKING:
    from backend.engine.core.program import Arena, Refs


class Import:
    """A frame from a Python block into a compiled one, copied into its arena row before the segment
    (once, when it is the same `SteadyFrame` tick after tick)."""

    def __init__(self, row: int, src: int, port: str, arena: Arena):
        self.row, self.src, self.port, self.arena = row, src, port, arena
        self.frame: PartialFrame | None = None
        self._values = arena.V[row]
        self._mask = arena.M[row]
        self._last_mask: np.ndarray | None = None
        self.due = -1  # the core tick in which its source last ticked (`CoreProgram.epoch`)
        self.events = False  # whether the frame last loaded carries events

    def load(self, results: list[dict[str, Any]]) -> bool:
        """Copy this tick's frame in; whether it carries events."""
        frame = results[self.src].get(self.port)
        if frame is self.frame and frame is not None and frame.steady:  # already in its row, unchanged
            return self.events
        self.frame = frame
        if frame is None:
            self.arena.A[self.row] = False
            self.events = False
            return False
        self.events = bool(frame.events)
        self.arena.A[self.row] = True
        self._values[:] = frame.values
        mask = frame.mask
        if mask is not self._last_mask:  # masks never change in place: the same object, the same mask
            self._mask[:] = mask
            self._last_mask = mask
        return self.events


class QuietMemo:
    """What a `QuietWhenIdle` block last ticked on (`params` None: look again), and its sleep: `seen` is
    `CHANGES` when it was last found quiet on its inputs (-1: look), which holds until a block changes
    (a command, an edit, a reset) or a source hands out new outputs (`due`) — when every source of it
    marks it (`sleeps`: Python steps and exposed inputs do; a compiled op does not)."""

    __slots__ = ("due", "inputs", "params", "seen", "sleeps", "state")

    def __init__(self, sleeps: bool):
        self.sleeps = sleeps
        self.inputs: list[Any] = []
        self.due = -1
        self.forget()

    def forget(self) -> None:
        self.params: Any = None
        self.state: Any = None
        self.seen = -1

    def still_quiet(self, block: Any, wires: tuple[tuple[str, int, str], ...], results: list[dict]) -> bool:
        """Whether a block that said it is quiet (the caller asked `block.quiet`) still holds the
        parameters, state and input values (the ones it reads) it last ticked on; then it sleeps, when it
        may."""
        if self.params is not block.params or self.state is not block.state:
            return False
        reads = block.quiet_reads
        for (port, src, src_port), old in zip(wires, self.inputs):
            if results[src].get(src_port) is not old and (reads is None or port in reads):
                return False
        if self.sleeps:
            self.seen = CHANGES[0]
        return True


class Segment:
    """Consecutive compiled steps: their imports, ops (table rows k0..k1-1), and the ops with Python
    work before (`pres`) and after (`posts`) the kernel. Events come into a segment only through its
    imports, the ops of an earlier segment and a `trap` (a clip player's own tick): while none carries
    any, the ops whose `post` only passes events skip it (`always`: the others)."""

    def __init__(self, ops: list[Op], imports: list[Import]):
        self.ops, self.imports = ops, imports
        self.k0, self.k1 = ops[0].k, ops[-1].k + 1
        self.pres = [op for op in ops if op.needs_pre()]
        self.posts = [op for op in ops if op.passes_events]
        self.always = [op for op in self.posts if op.post_always]
        self.had_events = True  # whether the ops' frames may hold events (cleared by a quiet tick's posts)
        self.watching = [op for op in ops if op.watches_changes]
        self.every = any(op.every_tick for op in self.pres)  # whether a `pre` runs every tick
        self.due = -1  # the core tick in which a Python source of an op's signals last ticked
        self.unbound = True  # an op was bound (or forgot its inputs) since the `pre`s last ran
        for op in ops:
            op.seg = self
        # `CHANGES` when every op was last found bound (-1: look again; blocks/block_state.py). While it
        # stands, no block holds another parameters or state object or handled a command, so, unless a
        # block ran its own tick, no op is stale (an op whose `pre` changes its block's arrays binds again
        # there) and no op's `changed` has anything new to see.
        self.seen = -1

    def look(self, refs: Refs) -> None:
        """A block changed (parameters, state, a command): bind every stale op again, and tell the ops
        that watch changes."""
        for op in self.ops:
            if op.stale():
                op.bind(refs)
        for op in self.watching:
            op.changed()
        self.seen = CHANGES[0]
