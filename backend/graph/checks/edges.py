"""Edges, one at a time in document order (`unknown_node`, `unknown_port`, `port_type_mismatch`,
`multiple_edges`), then the required inputs nothing feeds (`missing_input`).

An edge touching a node whose ports are unknown (a broken node) is checked only at its other end; it
still counts as an edge into its input and in the graph's shape, but the APU wires only edges whose
both ends are known.
"""

from __future__ import annotations

import difflib

from backend.engine.blocks.base import Port, port_accepts
from backend.graph.checks.state import CheckState
from backend.graph.issues import Issue
from backend.graph.schema import Edge, Endpoint


def check_edges(state: CheckState) -> None:
    assert state.program is not None
    for k, edge in enumerate(state.program.edges):
        _check_edge(state, edge, state.doc_index["edges"][k])


def _check_edge(state: CheckState, edge: Edge, i: int) -> None:
    src, dst = edge.from_, edge.to
    missing = [_unknown_node(state, edge, i, end, role) for end, role in ((src, "from"), (dst, "to"))]
    if any(missing):
        return
    src_ports, dst_ports = state.ports.get(src.node), state.ports.get(dst.node)
    out_ports = src_ports[1] if src_ports is not None else None
    in_ports = dst_ports[0] if dst_ports is not None else None
    bad_ports = [
        _unknown_port(state, i, src, out_ports, "output", "from"),
        _unknown_port(state, i, dst, in_ports, "input", "to"),
    ]
    if any(bad_ports):
        return
    if out_ports is not None and in_ports is not None:
        t_out, t_in = out_ports[src.port].type, in_ports[dst.port].type
        if not port_accepts(t_in, t_out):
            state.errors.append(
                Issue(
                    code="port_type_mismatch",
                    node=dst.node,
                    port=dst.port,
                    path=f"edges[{i}]",
                    message=f"cannot connect output '{src.node}.{src.port}' ({t_out.value}) to "
                    f"input '{dst.node}.{dst.port}' ({t_in.value})",
                )
            )
            return
    key = (dst.node, dst.port)
    if key in state.incoming:
        j, first = state.incoming[key]
        state.errors.append(
            Issue(
                code="multiple_edges",
                node=dst.node,
                port=dst.port,
                path=f"edges[{i}]",
                message=f"input '{dst.node}.{dst.port}' already has an edge from "
                f"'{first.from_.node}.{first.from_.port}' (edges[{j}]); an input takes "
                f"one edge (use a layer mixer to combine frames)",
            )
        )
        return
    state.incoming[key] = (i, edge)
    state.graph[src.node].add(dst.node)
    state.edge_at.setdefault((src.node, dst.node), (i, dst.port))
    if out_ports is not None and in_ports is not None:
        state.good_edges.append(edge)


def _unknown_node(state: CheckState, edge: Edge, i: int, end: Endpoint, role: str) -> bool:
    """Report an end naming no node (a node left out as malformed does exist)."""
    if end.node in state.node_by_id or end.node in state.broken:
        return False
    src, dst = edge.from_, edge.to
    hint = difflib.get_close_matches(end.node, list(state.node_by_id), n=1)
    extra = f"; did you mean '{hint[0]}'?" if hint else ""
    verb = "comes from" if role == "from" else "goes to"
    state.errors.append(
        Issue(
            code="unknown_node",
            node=end.node,
            port=end.port,
            path=f"edges[{i}].{role}.node",
            message=f"edge {src.node}.{src.port} -> {dst.node}.{dst.port} {verb} node "
            f"'{end.node}', which does not exist{extra}",
        )
    )
    return True


def _unknown_port(
    state: CheckState, i: int, end: Endpoint, ports: dict[str, Port] | None, kind: str, role: str
) -> bool:
    """Report an end naming a port its node does not have (unknown ports: nothing to check)."""
    if ports is None or end.port in ports:
        return False
    hint = difflib.get_close_matches(end.port, list(ports), n=1)
    extra = f"did you mean '{hint[0]}'? " if hint else ""
    state.errors.append(
        Issue(
            code="unknown_port",
            node=end.node,
            port=end.port,
            path=f"edges[{i}].{role}.port",
            message=f"node '{end.node}' ({state.node_by_id[end.node].type}) has no {kind} "
            f"'{end.port}'; {extra}{_ports_text(ports, kind)}",
        )
    )
    return True


def _ports_text(ports: dict[str, Port], kind: str) -> str:
    if not ports:
        return f"it has no {kind}s"
    return f"its {kind}s: " + ", ".join(f"{k} ({p.type.value})" for k, p in sorted(ports.items()))


def check_required_inputs(state: CheckState) -> None:
    for node_id, known in state.ports.items():
        if known is None:
            continue
        for name, port in known[0].items():
            if port.required and (node_id, name) not in state.incoming:
                state.errors.append(
                    Issue(
                        code="missing_input",
                        node=node_id,
                        port=name,
                        path=f"nodes[{state.node_index[node_id]}]",
                        message=f"node '{node_id}' ({state.node_by_id[node_id].type}) needs an "
                        f"edge into its '{name}' input ({port.type.value})",
                    )
                )
