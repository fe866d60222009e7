"""The Plan: what a checked, valid program compiles to, before any block exists.

A Plan is immutable: the steps in topological order (ties in document order), each a block class with
its validated parameters and the wires into its inputs, the output step, the APU level and the
stage-1 tap (the frame entering stage 2, the Pre-Viz's ghost). `Plan.instantiate` builds an APU from
it: fresh blocks, in their initial state, every time, so one plan can start any number of independent
APUs. Nothing in a Plan refers to a particular block type.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from backend.engine.apu import APU, Step, Wire
from backend.engine.blocks.base import Block, BlockContext, BlockParams, PortType, Role
from backend.engine.embodiment import Embodiment
from backend.graph.checks.state import CheckState
from backend.graph.schema import Program


@dataclass(frozen=True)
class PlannedStep:
    """One block to build: its node id, block class, parameters and input wires."""

    node_id: str
    block: type[Block]
    params: BlockParams
    wires: tuple[Wire, ...] = ()


@dataclass(frozen=True)
class Plan:
    program: Program  # the document, kept as the APU's source (for round trips); read-only
    robot: str  # the embodiment it was checked against
    steps: tuple[PlannedStep, ...]
    output: int  # index of the output step
    level: int
    stage1_tap: tuple[int, str] | None  # (step, port) of the frame entering stage 2
    # The blocks the checks built (fresh, never ticked) and the context they were built in: the first
    # APU instantiated in that context takes them over (building a block twice doubled compile time).
    # The program the steps were planned from: `program` with its subgraphs flattened (the same
    # document when it uses none); its node ids are the APU's.
    flat: Program | None = field(default=None, compare=False)
    _probes: dict = field(default_factory=dict, compare=False, repr=False)
    _probe_ctx: BlockContext | None = field(default=None, compare=False, repr=False)

    @property
    def params(self) -> Mapping[str, BlockParams]:
        """Every node's validated parameters, by node id (read-only)."""
        return MappingProxyType({s.node_id: s.params for s in self.steps})

    def instantiate(
        self, embodiment: Embodiment, ctx: BlockContext | None = None, *, rate: float = 100.0
    ) -> APU:
        """A new APU: fresh blocks (each with its own copy of its parameters) in their initial state.

        `ctx` is the context the blocks run in (a new one at `rate` if None); the program's exposed
        inputs that `ctx` does not hold yet get their defaults. Raises ValueError for another robot.
        """
        if embodiment.name != self.robot:
            raise ValueError(f"this plan was checked for robot '{self.robot}', not '{embodiment.name}'")
        ctx = ctx or BlockContext(embodiment=embodiment, rate=rate)
        probes = {}
        if ctx is self._probe_ctx and self._probes:
            probes = dict(self._probes)  # taken once: a second APU builds its own blocks
            self._probes.clear()
        steps = [
            Step(
                s.node_id,
                self._take(probes, s) or s.block(s.params.model_copy(deep=True), ctx, s.node_id),
                list(s.wires),
            )
            for s in self.steps
        ]
        for inp in self.program.inputs:
            ctx.inputs.setdefault(inp.name, inp.coerce(inp.default))
        return APU(steps, self.output, self.level, self.stage1_tap, source=self.program)

    @staticmethod
    def _take(probes: dict, step: PlannedStep) -> Block | None:
        """The checks' block for `step` when it is of the planned class (and not taken before)."""
        block = probes.pop(step.node_id, None)
        return block if type(block) is step.block else None

    @classmethod
    def from_checks(cls, state: CheckState) -> Plan:
        """The plan of a program whose checks found no error."""
        assert state.program is not None and not state.errors and len(state.outputs) == 1
        order = topological(state.ids, state.graph)
        index = {n: i for i, n in enumerate(order)}
        steps = []
        for n in order:
            wires = tuple(
                Wire(e.to.port, index[e.from_.node], e.from_.port) for e in state.good_edges if e.to.node == n
            )
            block = state.block_class(n)
            assert block is not None  # every node of a valid program has a known type
            steps.append(PlannedStep(n, block, state.params[n], wires))
        out = index[state.outputs[0]]
        return cls(
            program=state.document or state.program,
            flat=state.program,
            robot=state.embodiment.name,
            steps=tuple(steps),
            output=out,
            level=state.level or 0,
            stage1_tap=stage1_tap(steps, out),
            _probes=dict(state.probes),
            _probe_ctx=state.ctx,
        )


def topological(ids: list[str], graph: Mapping[str, set[str]]) -> list[str]:
    """Kahn's order, ties broken by document order (the graph is known to be acyclic)."""
    pos = {n: k for k, n in enumerate(ids)}
    indeg = {n: 0 for n in ids}
    for s in ids:
        for d in graph.get(s, ()):
            indeg[d] += 1
    order = [n for n in ids if indeg[n] == 0]
    k = 0
    while k < len(order):
        for d in sorted(graph.get(order[k], ()), key=pos.__getitem__):
            indeg[d] -= 1
            if indeg[d] == 0:
                order.append(d)
        k += 1
    return order


def stage1_tap(steps: list[PlannedStep], out: int) -> tuple[int, str] | None:
    """Walk back from the output through stage-2 blocks to the frame entering stage 2."""
    wire = next((w for w in steps[out].wires if w.port == "in"), None)
    crossed = False
    while wire is not None:
        src = steps[wire.src]
        if src.block.role is not Role.stage2:
            return (wire.src, wire.src_port) if crossed else None
        crossed = True
        frame_ins = src.block.ports(src.params)[0]
        wire = next(
            (
                w
                for w in src.wires
                if steps[w.src].block.role is not Role.signal
                and w.port in frame_ins
                and frame_ins[w.port].type is PortType.frame
            ),
            None,
        )
    return None
