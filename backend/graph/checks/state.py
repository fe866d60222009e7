"""The working notes of one check run, which the passes fill in one after the other.

Each pass reads what earlier passes found and adds issues and facts of its own; after the last pass
the notes either become a report with errors, or a report plus an immutable Plan
(`backend.graph.plan.Plan.from_checks`). Nothing here is kept after the run.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block, BlockContext, BlockParams, Port
from backend.engine.blocks.bypass import bypassed
from backend.engine.embodiment import Embodiment
from backend.graph.issues import Issue, ValidationReport
from backend.graph.schema import Edge, ExposedInput, Node, Program

if TYPE_CHECKING:
    from backend.graph.subgraphs import Flat

Ports = tuple[dict[str, Port], dict[str, Port]]


@dataclass
class CheckState:
    source: Any
    embodiment: Embodiment
    ctx: BlockContext
    max_level: int
    errors: list[Issue] = field(default_factory=list)
    warnings: list[Issue] = field(default_factory=list)
    # --- the document (checks.document) ---
    doc: dict[str, Any] | None = None
    program: Program | None = None  # what the passes check: the document with its subgraphs flattened
    document: Program | None = None  # the document as written (with its subgraphs)
    flat: Flat | None = None  # when the document uses subgraphs
    broken: dict[str, int] = field(default_factory=dict)  # ids of nodes left out as malformed -> index
    doc_index: dict[str, list[int]] = field(default_factory=dict)  # nodes/edges/inputs kept -> doc index
    # --- exposed inputs (checks.inputs) ---
    declared: dict[str, ExposedInput] = field(default_factory=dict)
    malformed_inputs: set[str] = field(default_factory=set)  # declared, but reported as schema errors
    read_inputs: set[str] = field(default_factory=set)  # names some node reads
    # --- nodes (checks.nodes) ---
    node_by_id: dict[str, Node] = field(default_factory=dict)
    node_index: dict[str, int] = field(default_factory=dict)
    params: dict[str, BlockParams] = field(default_factory=dict)  # nodes whose parameters are valid
    ports: dict[str, Ports | None] = field(
        default_factory=dict
    )  # None: the node exists, its ports are unknown
    probes: dict[str, Block] = field(default_factory=dict)  # blocks built to check their parameters
    # --- edges (checks.edges) ---
    incoming: dict[tuple[str, str], tuple[int, Edge]] = field(default_factory=dict)  # (node, port) -> edge
    graph: dict[str, set[str]] = field(default_factory=lambda: defaultdict(set))  # node -> downstream
    edge_at: dict[tuple[str, str], tuple[int, str]] = field(
        default_factory=dict
    )  # (src, dst) -> (edge, port)
    good_edges: list[Edge] = field(default_factory=list)  # edges the APU wires
    # --- graph (checks.graph) ---
    ids: list[str] = field(default_factory=list)  # the nodes of the graph, in document order
    outputs: list[str] = field(default_factory=list)
    level: int | None = None

    def block_class(self, node_id: str) -> type[Block] | None:
        """The class the node runs as: its block's, or that block's pass-through when bypassed."""
        node = self.node_by_id[node_id]
        cls = BLOCKS.get(node.type)
        return bypassed(cls) if cls is not None and node.bypass else cls

    def relocate(self) -> None:
        """Point issues about the inside of subgraphs at their place in the document (once, at the end)."""
        if self.flat is not None:
            self.errors = [self.flat.relocate(i) for i in self.errors]
            self.warnings = [self.flat.relocate(i) for i in self.warnings]

    def report(self) -> ValidationReport:
        if self.errors:
            return ValidationReport(valid=False, level=self.level, errors=self.errors, warnings=self.warnings)
        return ValidationReport(valid=True, level=self.level, warnings=self.warnings)
