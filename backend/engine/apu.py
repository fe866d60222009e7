"""The Animation Processing Unit: runs a compiled program's blocks in topological order each tick.

Levels (the paper's Nutty pipeline):
- 0: one block feeds the output;
- 1: a chain of blocks (sources and operators);
- 2: several chains (layers) blended by a layer mixer;
- 3: a second stage of post-processors (IK, motion filter, safety limits) before the output.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.engine.blocks.base import Block, Role
from backend.engine.core.program import KERNEL, CoreProgram
from backend.engine.frames import FrameEvent, PartialFrame
from backend.engine.profile import CookTimes

MAX_LEVEL = 3


class LevelError(ValueError):
    """A program needs a higher APU level than the engine allows."""


@dataclass(frozen=True)
class Wire:
    """Input `port` of a step reads output `src_port` of step `src`."""

    port: str
    src: int
    src_port: str


@dataclass
class Step:
    node_id: str
    block: Block
    wires: list[Wire] = field(default_factory=list)

    @property
    def type_name(self) -> str:
        return self.block.type_name


def required_level(roles: list[Role], frame_blocks: int) -> int:
    """The APU level a set of blocks (those feeding the output) needs."""
    if Role.stage2 in roles:
        return 3
    if Role.mixer in roles:
        return 2
    return 1 if frame_blocks > 1 else 0


class APU:
    """An immutable, ready-to-run program: ordered steps, the output step and the stage-1 tap.

    `stage1_tap` = (step index, port) of the frame entering the stage-2 post-processors: the
    pose before filtering/IK, which the Pre-Viz shows as the paper's *ghost*.
    `cook` holds the per-node cook times: one tick in `cook.every` is timed block by block.
    """

    def __init__(
        self,
        steps: list[Step],
        output: int,
        level: int,
        stage1_tap: tuple[int, str] | None = None,
        source: Any = None,
    ):
        self.steps = steps
        self.output = output
        self.level = level
        self.stage1_tap = stage1_tap
        self.source = source  # the program document this was compiled from (for round trips)
        self.index = {s.node_id: i for i, s in enumerate(steps)}
        self.results: list[dict[str, Any]] = [{} for _ in steps]
        emb = steps[output].block.emb
        self._stage1_held = emb.rest.copy()
        # The wiring as plain tuples (port, source step, source port): read on every tick.
        self._wires = [tuple((w.port, w.src, w.src_port) for w in s.wires) for s in steps]
        # What the tick loop walks: (step index, block, wires) of every step, in order.
        self._plan = tuple((i, s.block, wires) for i, (s, wires) in enumerate(zip(steps, self._wires)))
        self.cook = CookTimes([s.node_id for s in steps], [s.type_name for s in steps])
        self._untimed = 0  # ticks since the last timed one
        # The compiled core (backend/engine/core): the compiled blocks as a few kernel calls per tick.
        self.core = CoreProgram.build(self)
        self._core_results = False  # whether `results` holds the core's frames (else the blocks' own)

    def block(self, node_id: str) -> Block:
        return self.steps[self.index[node_id]].block

    def blocks_of(self, role: Role) -> list[Block]:
        return [s.block for s in self.steps if s.block.role is role]

    def plain_next(self) -> bool:
        """Whether the next tick is a plain one: not timed block by block, and with the core's frames
        already in `results` when the core runs it (the tick after a timed one puts them back)."""
        if self._untimed + 1 >= self.cook.every:
            return False
        return self.core is None or self._core_results or not self.core.loaded()

    def tick(self, dt: float) -> tuple[np.ndarray, np.ndarray, list[FrameEvent]]:
        """Run every step once. Returns (final positions (C,), stage-1 positions (C,), events)."""
        results = self.results
        self._untimed += 1
        core = self.core
        if self._untimed >= self.cook.every:
            self._untimed = 0
            if core is not None and self._core_results:
                core.settle(results)  # the blocks' state as the core left it (some is written back lazily)
            self._tick_timed(dt)  # block by block, each its own tick (on the same state as the core's)
            if core is not None:
                core.verify()
                self._core_results = False
        elif core is not None and (KERNEL.entry is not None or core.ready()):  # (loaded: no call)
            if not self._core_results:
                core.restore_results(results)
                self._core_results = True
            core.tick(dt, results)
        else:
            self._core_results = False
            for i, block, wires in self._plan:
                inputs = {}
                for port, src, src_port in wires:  # a plain loop: cheaper than a comprehension's call
                    inputs[port] = results[src].get(src_port)
                results[i] = block.tick(dt, inputs) or {}
        final: PartialFrame = results[self.output]["frame"]
        if self.stage1_tap is None:
            stage1 = final.values
        else:
            tapped: PartialFrame | None = results[self.stage1_tap[0]].get(self.stage1_tap[1])
            if tapped is not None:
                np.copyto(self._stage1_held, tapped.values, where=tapped.mask)
            stage1 = self._stage1_held
        return final.values, stage1, final.events

    def _tick_timed(self, dt: float) -> None:
        """The same loop, with each block's cook time (ns) written to `cook.row`."""
        results, row, clock = self.results, self.cook.row, time.perf_counter_ns
        start = clock()
        for i, block, wires in self._plan:
            t0 = clock()
            inputs = {}
            for port, src, src_port in wires:
                inputs[port] = results[src].get(src_port)
            results[i] = block.tick(dt, inputs) or {}
            row[i] = clock() - t0
        row[-1] = clock() - start
        self.cook.record()

    def adopt_state_from(self, old: APU) -> list[str]:
        """Blocks whose id and type survive keep their state. Returns the ids that kept it.

        A block moved into or out of a subgraph changes only the path of its id (`breathe` grouped
        into `idle` runs as `idle/breathe`): a block whose id is new takes the state of the one old
        block of its type whose id is gone and ends with the same name, when there is exactly one.
        """
        if old.core is not None and old._core_results:
            old.core.settle(old.results)  # the old blocks' state as the core left it
        kept = []
        unmatched = []
        for step in self.steps:
            j = old.index.get(step.node_id)
            if j is None:
                unmatched.append(step)
                continue
            prev = old.steps[j].block
            if type(prev) is type(step.block):
                step.block.adopt_state(prev)
                kept.append(step.node_id)
        if unmatched:
            gone: dict[tuple[str, type], list[Any]] = {}
            for st in old.steps:
                if st.node_id not in self.index:
                    gone.setdefault((st.node_id.rsplit("/", 1)[-1], type(st.block)), []).append(st.block)
            wanted: dict[tuple[str, type], list[Step]] = {}
            for step in unmatched:
                wanted.setdefault((step.node_id.rsplit("/", 1)[-1], type(step.block)), []).append(step)
            for key, steps in wanted.items():
                if len(steps) == 1 and len(gone.get(key, [])) == 1:
                    steps[0].block.adopt_state(gone[key][0])
                    kept.append(steps[0].node_id)
        self._stage1_held = (
            old._stage1_held.copy()
            if old._stage1_held.shape == self._stage1_held.shape
            else self._stage1_held
        )
        return kept

    def signal_value(self, node_id: str, port: str) -> Any:
        """The latest value on an output port (for telemetry); None before the first tick. A frame of a
        compiled step is rewritten in place each tick: read it between ticks, or use `signal_values`."""
        i = self.index.get(node_id)
        if i is None:
            return None
        if self.core is not None and self._core_results:  # (some compiled outputs are worked out on demand)
            self.core.refresh(i, self.results)
        return self.results[i].get(port)

    def signal_values(self, ports: list[tuple[str, str]]) -> list[Any]:
        """The latest values on (node, port) pairs, frames copied: called under the engine's `tick_lock`
        (as telemetry does), a snapshot of one tick that later ticks leave as it is."""
        values = [self.signal_value(node, port) for node, port in ports]
        return [v.copy() if isinstance(v, PartialFrame) else v for v in values]
