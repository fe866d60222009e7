"""A program's compiled core: its compiled blocks as op tables over one frame arena, run by the kernel
(backend/engine/core/vm.py) a segment at a time, with the other blocks ticking in Python between.

Built when the APU is (`Plan.instantiate`): every step whose block has an op (backend/engine/core/ops.py)
becomes a row of the op table, and each run of consecutive compiled steps a segment, one kernel call.
A compiled step writes its frame to its arena row instead of allocating one, and Python readers
(Python blocks, telemetry probes, the stage-1 tap) see it through one `PartialFrame` per step, made
once: its values are the row; its mask is a copy that is replaced, never changed in place, when the
row's mask changes; its events are passed along in Python.

A Python block that says its tick would change nothing (`quiet`, backend/engine/blocks/quiet.py: an
idle voice, face, posture, …) is skipped while its params, state and inputs are the objects it last
ticked on. An exposed input is not ticked: its value is read when the values changed (`InputValues`).
A frame from a Python block into a compiled one is copied into an import row before the segment
(`Import`). Python work that only follows a Python step's outputs (an import's copy, the `pre` of an
op whose signals come from Python) runs in the ticks that step handed out new ones (`due`). Commands,
events, swaps and blocks without an op keep the Python path. One tick in `CookTimes.every` the APU
times blocks one by one with their own ticks, which step the same state, and `verify` then checks that
no block replaced an array the table lists.

The kernel loads (from numba's cache, or compiles on a fresh clone) on a thread of its own, started
by the second tick of a core: until it is there, the APU runs the blocks' own ticks, which step the same
state, so the switch is seamless and no start waits for it.

`NUTTY_CORE=0` turns the core off (each block ticks on its own, compiled or not), for comparisons.
"""

from __future__ import annotations

import heapq
import logging
import os
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.blocks.base import PortType
from backend.engine.blocks.block_state import CHANGES
from backend.engine.blocks.core import ExposedInput
from backend.engine.blocks.input_values import InputValues
from backend.engine.blocks.quiet import QuietWhenIdle
from backend.engine.compiled.lazy_entry import LazyEntry, LoadOnSecondAsk
from backend.engine.compiled.pointers import AddressTable
from backend.engine.core import vm
from backend.engine.core.ops import Op
from backend.engine.core.registry import op_class
from backend.engine.core.segments import Import, QuietMemo, Segment
from backend.engine.core.signal_ops import compiles_signal, output_slot, takes_in_kernel

if TYPE_CHECKING:
    from backend.engine.apu import APU

log = logging.getLogger(__name__)

#: Environment variable: "0" turns the compiled core off.
CORE_ENV = "NUTTY_CORE"


def core_enabled() -> bool:
    return os.environ.get(CORE_ENV, "").strip() not in ("0", "false", "no")


#: The kernel, loaded once per process on a thread of its own (started by a core's second tick).
KERNEL = LazyEntry(vm.run_ops, vm.RUN_SIG, "core-kernel")


class Arena:
    """The frames of the compiled steps: values `V` and masks `M` (rows, C), rows present `A`, published
    masks `P` with their change flags `CH`, the scalar slots `S`, the op table `ops` and its `service`
    flags `SV`."""

    def __init__(self, rows: int, channels: int, n_ops: int):
        self.V = np.zeros((rows, channels))
        self.M = np.zeros((rows, channels), dtype=bool)
        self.A = np.zeros(rows, dtype=bool)
        self.P = np.zeros((rows, channels), dtype=bool)
        self.CH = np.zeros(rows, dtype=bool)
        self.S = np.zeros(0)
        self.ops = np.full((n_ops, vm.WIDTH), -1, dtype=np.int64)
        self.SV = np.zeros(max(n_ops, 1), dtype=bool)  # per op: it asked for `service` (vm.py)
        self._slots = 0
        self.dt: float | None = None  # the last tick's dt (s); None before the first core tick

    def scalar_slots(self, n: int) -> int:
        """Reserve `n` scalar slots; the index of the first."""
        first = self._slots
        self._slots += n
        self.S = np.zeros(max(self._slots, 1))
        return first


class Refs(AddressTable):
    """The table of arrays the kernel reads by address (vm.py): the arena's and the robot's arrays, then
    `vm.WIDTH` rows per op."""

    def __init__(self, n_ops: int):
        super().__init__(vm.FIRST_OP_REF + n_ops * vm.WIDTH)

    def put(self, k: int, col: int, array: np.ndarray) -> int:
        """List `array` for column `col` of op `k`; its row in the table."""
        return self.put_at(vm.FIRST_OP_REF + k * vm.WIDTH + col, array)


class CoreProgram:
    """The compiled core of one APU (see the module doc)."""

    def __init__(self, apu: APU, compiled: dict[int, type[Op]]):
        steps = apu.steps
        emb = steps[apu.output].block.emb
        self.emb = emb
        frame_ports = {i: _frame_ports(steps[i].block) for i in compiled}
        n_imports = sum(
            1 for i in compiled for w in steps[i].wires if w.port in frame_ports[i] and w.src not in compiled
        )
        self.arena = arena = Arena(len(compiled) + n_imports, emb.n_channels, len(compiled))
        self.refs = Refs(len(compiled))
        self.ops: list[Op] = []
        by_step: dict[int, Op] = {}
        imports: dict[tuple[int, str], Import] = {}
        # ("py", step, block, wires, QuietMemo or None, readers), ("input", step, block, seen, readers) or
        # ("core", segment). An input's `seen` is the [version, value, values] it last read (version None:
        # read again); readers are the imports, ops, segments and quiet memos marked `due` when the step
        # hands out new outputs.
        self.plan: list[tuple[Any, ...]] = []
        readers: dict[int, list[Any]] = {}  # Imports, Ops, Segments and QuietMemos: each has a `due`
        row = 0
        current: list[Op] = []
        current_imports: list[Import] = []
        for i in run_order(apu, compiled):
            step = steps[i]
            if i not in compiled:
                if current:
                    self.plan.append(("core", Segment(current, current_imports)))
                    current, current_imports = [], []
                readers[i] = []
                if type(step.block) is ExposedInput and "tick" not in vars(step.block):
                    self.plan.append(("input", i, step.block, [None, None, None], readers[i]))
                    continue  # read when the values changed, not ticked (blocks/input_values.py)
                memo = None
                if isinstance(step.block, QuietWhenIdle):
                    sources = {src for _, src, _ in apu._wires[i]}
                    memo = QuietMemo(sleeps=sources <= readers.keys())  # (every source marks it `due`)
                    for src in sources & readers.keys():
                        readers[src].append(memo)
                self.plan.append(("py", i, step.block, apu._wires[i], memo, readers[i]))
                continue
            signals = [w for w in step.wires if w.port not in frame_ports[i]]
            if _reads_from(signals, current, by_step, compiled[i]):  # this tick's: a segment after them
                self.plan.append(("core", Segment(current, current_imports)))
                current, current_imports = [], []
            wired = {w.port: w for w in step.wires}
            srcs: list[Any] = []
            for port in frame_ports[i]:
                w = wired.get(port)
                if w is None or w.src in by_step:
                    srcs.append(None if w is None else by_step[w.src])
                    continue
                if (w.src, w.src_port) not in imports:
                    imp = imports[w.src, w.src_port] = Import(
                        len(compiled) + len(imports), w.src, w.src_port, arena
                    )
                    current_imports.append(imp)
                srcs.append(imports[w.src, w.src_port])
            op = compiled[i](len(self.ops), i, step.block, arena, row, srcs)
            _wire_signals(op, signals, by_step, readers)
            row += 1
            self.ops.append(op)
            by_step[i] = op
            current.append(op)
        if current:
            self.plan.append(("core", Segment(current, current_imports)))
        for imp in imports.values():
            readers[imp.src].append(imp)
        self._link_readers(steps, by_step, readers)
        #: Ops whose outputs a probe must have brought up to date (`refresh`), by step.
        self.refreshed = {op.step: op for op in self.ops if type(op).refresh is not Op.refresh}
        self.epoch = 0  # core ticks so far
        for op in self.ops:
            op.bind(self.refs)
        shared = (arena.V, arena.M, arena.A, arena.P, arena.CH, arena.S, emb.rest, emb.min, emb.max,
                  emb.enum_mask, arena.SV)  # fmt: skip
        for j, array in enumerate(shared):  # (vm.REF_V …)
            self.refs.put_at(j, np.ascontiguousarray(array))
        self.rebinds = 0  # binds found necessary by `verify` (a block replaced a listed array unannounced)
        self._kernel = LoadOnSecondAsk(KERNEL)

    def _link_readers(self, steps: list[Any], by_step: dict[int, Op], readers: dict[int, list[Any]]) -> None:
        """Mark the ops whose signal outputs a step reads in Python (not the kernel: `outputs_read`), and
        make each segment a reader of the Python sources of its ops' `pre`s (it is `due` when they tick)."""
        for j, step in enumerate(steps):  # a signal output of an op read in Python by any step
            for w in step.wires:
                src = by_step.get(w.src)
                if src is not None and w.src_port not in _frame_ports(src.block, outputs=True):
                    src.outputs_read = src.outputs_read or not takes_in_kernel(
                        src, w.src_port, by_step.get(j), w.port
                    )
        for entry in self.plan:  # a segment is due (its `pre`s look) when a Python source of theirs ticked
            if entry[0] == "core":
                for src in {src for op in entry[1].pres for _, src, _ in op.signal_ports if src in readers}:
                    readers[src].append(entry[1])

    @classmethod
    def build(cls, apu: APU) -> CoreProgram | None:
        """The core of `apu`, or None when none of its blocks compiles (or the core is turned off)."""
        if not core_enabled():
            return None
        compiled = {}
        for i, step in enumerate(apu.steps):
            op = op_class(step.block)
            if op is not None:
                compiled[i] = op
        readers: dict[int, list[tuple[str, type[Op] | None, str]]] = {i: [] for i in compiled}
        for j, step in enumerate(apu.steps):
            for w in step.wires:
                if w.src in readers:
                    readers[w.src].append((w.src_port, compiled.get(j), w.port))
        for i in [i for i, op in compiled.items() if not compiles_signal(op, readers[i])]:
            del compiled[i]  # (its readers are then Python's or its readers' own Python `pre`)
        return cls(apu, compiled) if compiled else None

    def ready(self) -> bool:
        """Whether the kernel has loaded (until then the APU runs the blocks' own ticks); the second ask
        (the second tick) starts loading it (`LoadOnSecondAsk`)."""
        return KERNEL.entry is not None or self._kernel.ready()

    def loaded(self) -> bool:
        """Whether the kernel has loaded, without asking for it (`ready` counts as an ask)."""
        return KERNEL.entry is not None

    def restore_results(self, results: list[dict[str, Any]]) -> None:
        """Put the compiled steps' frames back in `results` (after the APU ran the blocks' own ticks)."""
        for op in self.ops:
            op.restore(results)
        for entry in self.plan:
            if entry[0] == "core":
                entry[1].had_events = entry[1].unbound = True  # (its ops forget their inputs, below)
                entry[1].seen = -1  # the blocks' own ticks may have replaced arrays: look at every op
                for imp in entry[1].imports:
                    imp.frame = None  # their sources ticked on their own: load each import once more
            elif entry[0] == "input":
                entry[3][0] = None  # read again
            elif entry[4] is not None:
                entry[4].forget()  # the block's own tick ran on other inputs, maybe: no skip until it ticks

    def tick(self, dt: float, results: list[dict[str, Any]]) -> None:
        """One tick of the whole program: Python steps as the APU runs them, segments in the kernel."""
        ops, run, refs, changes = self.arena.ops, KERNEL.entry, self.refs.table, CHANGES
        if dt != self.arena.dt:
            self._new_dt(dt)
        self.epoch += 1
        epoch = self.epoch
        carried = False  # whether an earlier segment's frames carry events this tick (a later one reads them)
        for entry in self.plan:
            kind = entry[0]
            if kind == "input":
                _, i, block, seen, due = entry
                values = block.ctx.inputs  # (a context's values may be replaced: a swap's)
                version = values.version if type(values) is InputValues else None
                if version is None or version != seen[0] or values is not seen[2]:
                    seen[0], seen[2] = version, values
                    value = values.get(block.params.name)
                    if value is not seen[1] or not results[i]:
                        seen[1] = value
                        results[i] = {"value": value}  # ExposedInput.tick
                        for r in due:
                            r.due = epoch
                continue
            if kind == "py":
                _, i, block, wires, memo, due = entry
                if memo is not None and (
                    (memo.seen == changes[0] and memo.due != epoch)  # asleep: nothing reached it since
                    or (block.quiet and memo.still_quiet(block, wires, results))  # (then it may sleep)
                ):
                    continue  # quiet, on the inputs it reads: its last outputs stand (blocks/quiet.py)
                inputs = {}
                for port, src, src_port in wires:
                    inputs[port] = results[src].get(src_port)
                results[i] = block.tick(dt, inputs) or {}
                if memo is not None:  # what it ticked on; awake (seen -1) until it is found quiet
                    memo.params, memo.state, memo.inputs, memo.seen = (
                        block.params,
                        block.state,
                        [*inputs.values()],
                        -1,
                    )
                for r in due:
                    r.due = epoch
                continue
            seg: Segment = entry[1]
            events = carried
            for imp in seg.imports:  # a source that did not tick hands out the frame already loaded
                if imp.due == epoch or imp.frame is None:
                    if imp.load(results):
                        events = True
                elif imp.events:
                    events = True
            if seg.seen != changes[0]:  # a block changed (parameters, state, a command): look at its ops
                seg.look(self.refs)
            if seg.every or seg.due == epoch or seg.unbound:  # (else no op's `pre` has anything new)
                seg.unbound = False
                for op in seg.pres:  # the signals an op reads changed only if a source ticked
                    if op.every_tick or op.due == epoch or op._signals is None:
                        op.pre(dt, results)
            changed = run(ops, refs, seg.k0, seg.k1, dt)
            if changed >= vm.TRAP:  # an op needs Python first: its `trap`, then the rest of the segment
                changed, trapped = self._traps(changed, seg, dt, results)
                events = events or trapped
            if changed:
                if changed >= vm.SERVICE:
                    self._service()
                if changed % vm.SERVICE:
                    self._publish(results)
            for op in seg.posts if events or seg.had_events else seg.always:
                op.post()
            seg.had_events = carried = events

    def _traps(
        self, changed: int, seg: Segment, dt: float, results: list[dict[str, Any]]
    ) -> tuple[int, bool]:
        """The kernel stopped at an op that needs Python first (`changed` >= vm.TRAP): its `trap`, then the
        rest of the segment, as often as it asks. The kernel's final count, and whether a trap gave out
        events."""
        events = False
        while changed >= vm.TRAP:
            k = changed // vm.TRAP - 1
            self._publish(results)  # what its Python reads is this tick's (a lazy signal's too)
            if self.ops[k].trap(dt, results):
                events = True
            changed = changed % vm.TRAP + KERNEL.entry(self.arena.ops, self.refs.table, k, seg.k1, dt)
        return changed, events

    def _new_dt(self, dt: float) -> None:
        self.arena.dt = dt
        for op in self.ops:
            op.new_dt(dt)

    def _service(self) -> None:
        """Python's part after the kernel for the ops that asked for it (`SV`): only those are touched."""
        flagged = self.arena.SV
        for k in flagged.nonzero()[0].tolist():
            flagged[k] = False
            self.ops[k].service()

    def _publish(self, results: list[dict[str, Any]]) -> None:
        """Show Python readers the outputs the kernel flagged changed (`CH`): only those ops are touched."""
        changed = self.arena.CH
        for row in changed.nonzero()[0].tolist():
            changed[row] = False
            self.ops[row].publish(results)  # (an op's row is its index in the table)

    def refresh(self, step: int, results: list[dict[str, Any]]) -> None:
        """Bring the outputs of step `step` up to date for a probe, when its op works them out lazily."""
        op = self.refreshed.get(step)
        if op is not None:
            op.refresh(results)

    def settle(self, results: list[dict[str, Any]]) -> None:
        """Bring every lazily published output and the state behind it up to date in the blocks (before
        their own ticks run, or a new program adopts their state)."""
        for op in self.refreshed.values():
            op.refresh(results)

    def listed(self, op: Op, count: int) -> list[np.ndarray | None]:
        """The first `count` arrays the table lists for `op`, in its column order."""
        first = vm.FIRST_OP_REF + op.k * vm.WIDTH
        return [self.refs.held(first + col) for col in range(4, 4 + count)]

    def verify(self) -> None:
        """Bind again every op whose block holds other arrays than the table lists (there should be none:
        each such case is a missed staleness rule, counted in `rebinds` and logged)."""
        for op in self.ops:
            if op.stale():
                continue  # the next tick binds it anyway
            held = op.arrays()  # what the block holds now: what `bind` would list
            if any(x is not y for x, y in zip(held, self.listed(op, len(held)))):
                self.rebinds += 1
                log.warning("compiled core: %s replaced an array unannounced; bound again", op.block.node_id)
                op.bind(self.refs)


def _reads_from(signals: list[Any], ops: list[Op], by_step: dict[int, Op], reader: type[Op]) -> bool:
    """Whether an op of class `reader`, with these signal wires, reads in its `pre` (not in the kernel)
    an output of one of `ops`: made in the same kernel run, after its `pre`."""
    return any(
        by_step.get(w.src) in ops and not takes_in_kernel(by_step[w.src], w.src_port, reader, w.port)
        for w in signals
    )


def _wire_signals(op: Op, signals: list[Any], by_step: dict[int, Op], readers: dict[int, list[Any]]) -> None:
    """Tell `op` the signals wired into it (`signals`: its wires that are not frames): which the kernel
    carries from a compiled signal (`drive_wires`), which its `pre` reads (`signal_ports`), and mark it a
    reader of their Python sources (it becomes `due` when they tick)."""
    in_kernel = [w for w in signals if takes_in_kernel(by_step.get(w.src), w.src_port, op, w.port)]
    op.signal_ports = tuple((w.port, w.src, w.src_port) for w in signals if w not in in_kernel)
    op.input_wires = tuple((w.port, w.src, w.src_port) for w in signals)
    op.drive_wires = tuple((w.port, output_slot(by_step[w.src], w.src_port)) for w in in_kernel)
    op.every_tick = op.pre_when == "always" or any(src in by_step for _, src, _ in op.signal_ports)
    for src in {src for _, src, _ in op.signal_ports if src in readers}:
        readers[src].append(op)


def run_order(apu: APU, compiled: dict[int, Any]) -> list[int]:
    """An order of the APU's steps that runs the compiled ones in as few segments as it can.

    Any order that runs each step after the steps it reads from computes the same frames; the Python
    steps keep their order among themselves (their notifications to the engine keep theirs). Steps are
    taken in runs of one kind, Python first: while a step of the current kind is ready, the first
    ready one of that kind is taken (Python steps first lets the compiled ones that read them wait and
    run together)."""
    n = len(apu.steps)
    after: list[set[int]] = [{w.src for w in step.wires} for step in apu.steps]
    python = [i for i in range(n) if i not in compiled]
    for earlier, later in zip(python, python[1:]):
        after[later].add(earlier)
    waiting = [len(deps) for deps in after]
    readers: list[list[int]] = [[] for _ in range(n)]
    for i, deps in enumerate(after):
        for d in deps:
            readers[d].append(i)
    ready: dict[bool, list[int]] = {True: [], False: []}  # by "is Python"
    for i in range(n):
        if not waiting[i]:
            heapq.heappush(ready[i not in compiled], i)
    order: list[int] = []
    kind = True
    while ready[True] or ready[False]:
        if not ready[kind]:
            kind = not kind
        pick = heapq.heappop(ready[kind])
        order.append(pick)
        for r in readers[pick]:
            waiting[r] -= 1
            if not waiting[r]:
                heapq.heappush(ready[r not in compiled], r)
    return order


def _frame_ports(block: Any, outputs: bool = False) -> tuple[str, ...]:
    """The block's frame input ports, in the order its op lists them (or its frame output ports)."""
    ports = block.ports(block.params)[1 if outputs else 0]
    return tuple(name for name, port in ports.items() if port.type is PortType.frame)
