"""Nodes, one at a time in document order: a unique id, a known block type, valid parameters, its
ports, the block class's own check, DoFs on this robot, and whether the block can be configured.

A node stops at its first broken step (one broken thing, one error), except that a failure to derive
its ports is reported and the node goes on with its ports unknown. Later, once the edges are known,
`check_wiring` gives every block class its say on how its node is wired.
"""

from __future__ import annotations

import difflib

from pydantic import ValidationError

from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block, BlockParams
from backend.engine.blocks.bypass import pass_through
from backend.engine.selectors import SelectorError
from backend.graph.checks.dofs import dof_errors, find_value
from backend.graph.checks.hooks import NodeCheck
from backend.graph.checks.params import params_errors, walk_loc
from backend.graph.checks.state import CheckState
from backend.graph.checks.text import loc
from backend.graph.issues import Issue
from backend.graph.schema import Node


def check_nodes(state: CheckState) -> None:
    assert state.program is not None
    for k, node in enumerate(state.program.nodes):
        _check_node(state, node, state.doc_index["nodes"][k])


def _check_node(state: CheckState, node: Node, i: int) -> None:
    if node.id in state.node_by_id or node.id in state.broken:
        first = state.node_index.get(node.id, state.broken.get(node.id))
        state.errors.append(
            Issue(
                code="duplicate_node",
                node=node.id,
                path=f"nodes[{i}].id",
                message=f"node id '{node.id}' is used twice (nodes[{first}] "
                f"and nodes[{i}]); ids must be unique",
            )
        )
        return
    state.node_by_id[node.id] = node
    state.node_index[node.id] = i
    state.ports[node.id] = None
    cls = BLOCKS.get(node.type)
    if cls is None:
        hint = difflib.get_close_matches(node.type, list(BLOCKS), n=1)
        extra = f"; did you mean '{hint[0]}'?" if hint else f" (known: {', '.join(sorted(BLOCKS))})"
        state.errors.append(
            Issue(
                code="unknown_block_type",
                node=node.id,
                path=f"nodes[{i}].type",
                message=f"node '{node.id}' has type '{node.type}', which is not a block{extra}",
            )
        )
        return
    params = _params(state, node, i, cls)
    if params is None:
        return
    state.params[node.id] = params
    try:
        state.ports[node.id] = cls.ports(params)
    except Exception as exc:  # noqa: BLE001 (any fault of a block's port rules becomes an issue on its node)
        state.errors.append(
            Issue(
                code="block_config",
                node=node.id,
                path=f"nodes[{i}].params",
                message=f"node '{node.id}' ({node.type}): cannot derive its ports: {exc}",
            )
        )
    if node.bypass and state.ports[node.id] is not None and pass_through(cls, params) is None:
        state.errors.append(
            Issue(
                code="cannot_bypass",
                node=node.id,
                path=f"nodes[{i}].bypass",
                message=f"node '{node.id}' ({node.type}) cannot be bypassed: "
                + ("it guards the robot" if not cls.can_bypass else "it has no frame to pass through"),
            )
        )
        return
    own = NodeCheck(state, node, i)
    cls.check(params, own)
    if own.ports_in_doubt:
        state.ports[node.id] = None  # its ports are in doubt: do not check its edges against them
    if own.failed:
        return
    dof_issues = dof_errors(node, i, params, state.embodiment)
    state.errors.extend(dof_issues)
    if not dof_issues:
        _probe(state, node, i, state.block_class(node.id) or cls, params)


def _params(state: CheckState, node: Node, i: int, cls: type[Block]) -> BlockParams | None:
    """The node's parameters validated by its block's model (None: reported)."""
    try:
        return cls.Params.from_json_value(node.params)
    except ValidationError as exc:
        state.errors.extend(params_errors(node, i, cls, exc))
    except Exception as exc:  # noqa: BLE001 (a block's own validator misbehaving is reported on its node)
        state.errors.append(
            Issue(
                code="block_config",
                node=node.id,
                path=f"nodes[{i}].params",
                message=f"node '{node.id}' ({node.type}): parameters rejected: {exc}",
            )
        )
    return None


def _probe(state: CheckState, node: Node, i: int, cls: type[Block], params: BlockParams) -> None:
    """Configure the block once on this robot, to hear whether it accepts its parameters as a whole.

    The probe is a fresh block with its own copy of the parameters, as `Plan.instantiate` would build
    it: kept in `state.probes`, the first APU instantiated in the same context takes it over instead of
    building the block a second time.
    """
    try:
        state.probes[node.id] = cls(params.model_copy(deep=True), state.ctx, node.id)
    except SelectorError as exc:
        where = find_value(params.model_dump(mode="json"), exc.selector) or ()
        parts = walk_loc(cls.Params, where)[0] if where else []
        state.errors.append(
            Issue(
                code="unknown_dof",
                node=node.id,
                port=loc(parts) if parts else None,
                path=loc((f"nodes[{i}].params", *where)),
                message=f"node '{node.id}' ({node.type}): {exc}",
            )
        )
    except Exception as exc:  # noqa: BLE001 (configure() says the parameters do not fit this robot: reported)
        state.errors.append(
            Issue(
                code="block_config",
                node=node.id,
                path=f"nodes[{i}].params",
                message=f"node '{node.id}' ({node.type}) cannot be set up on robot "
                f"'{state.embodiment.name}': {exc}",
            )
        )


def check_wiring(state: CheckState) -> None:
    """Every block class's `check_wiring` hook, for the nodes whose parameters are valid."""
    for node_id, params in state.params.items():
        cls = state.block_class(node_id)
        assert cls is not None  # a node has parameters only if its type is known
        cls.check_wiring(params, NodeCheck(state, state.node_by_id[node_id], state.node_index[node_id]))
