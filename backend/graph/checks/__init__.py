"""The program checks: small passes, run in order over one `CheckState`, that find every error at once.

| pass | module | codes |
|---|---|---|
| read the document | document | malformed_json, wrong_format, schema, invalid_input (shape) |
| exposed input declarations | inputs | duplicate_input, invalid_input |
| subgraphs flattened (with reading the document) | subgraphs | unknown_subgraph, subgraph_cycle, unknown_exposed_port |
| nodes (incl. the block classes' `check` hooks) | nodes | duplicate_node, unknown_block_type, unknown_param, invalid_param, block_config, unknown_dof, + the hooks' codes |
| exposed ports of subgraphs | subgraphs | unknown_port |
| edges | edges | unknown_node, unknown_port, port_type_mismatch, multiple_edges |
| required inputs | edges | missing_input |
| loops | graph | cycle |
| the output | graph | no_output, multiple_outputs |
| the level | graph | level_too_high, unconnected_node |
| the block classes' `check_wiring` hooks | nodes | (warnings such as zero_weight_layer, empty_layer) |
| unread inputs | inputs | unused_input |

The order of the passes is the order of the issues in the report. When the document cannot be read
as a program, the later passes do not run. A run with no errors becomes an immutable Plan
(`backend.graph.plan`).

No pass names a block type. `output` and `input` nodes are blocks like any other (registered, with
parameters, ports and a tick); what the format says about them is expressed without their names:
"exactly one output" is "exactly one node whose block has `Role.output`" (graph), the level follows
from roles, and an `input` node's declaration rules are its class's `check` hook
(`ExposedInput.check`), which reports through `NodeCheck.read_input` which inputs are read.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from backend.engine.blocks.base import BlockContext
from backend.engine.embodiment import Embodiment
from backend.graph.checks import edges, graph, inputs, nodes
from backend.graph.checks.document import read_document
from backend.graph.checks.exposed import check_exposed
from backend.graph.checks.hooks import NodeCheck
from backend.graph.checks.state import CheckState

Pass = Callable[[CheckState], None]

PASSES: tuple[Pass, ...] = (
    inputs.check_declarations,
    nodes.check_nodes,
    check_exposed,
    edges.check_edges,
    edges.check_required_inputs,
    graph.check_cycles,
    graph.check_output,
    graph.check_level,
    nodes.check_wiring,
    inputs.check_unused,
)


def run_checks(source: Any, embodiment: Embodiment, *, max_level: int, ctx: BlockContext) -> CheckState:
    """Every check of `source` against `embodiment`; the state holds the issues and what was learnt.

    `ctx` is what blocks are configured against when probed (resources such as postures and clips).
    """
    state = CheckState(source=source, embodiment=embodiment, ctx=ctx, max_level=max_level)
    read_document(state)
    if state.program is None:
        return state
    for check in PASSES:
        check(state)
    state.relocate()
    return state


__all__ = ["PASSES", "CheckState", "NodeCheck", "run_checks"]
