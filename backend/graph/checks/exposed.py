"""The subgraph pass after the nodes: exposed ports must name ports of their inner blocks."""

from __future__ import annotations

import difflib

from backend.graph.checks.state import CheckState
from backend.graph.issues import Issue


def check_exposed(state: CheckState) -> None:
    """After the nodes pass: every exposed port names a port its inner block has (`unknown_port`), and
    edges through a bad exposed port are left out (one broken thing gives one error)."""
    flat, program = state.flat, state.program
    if flat is None or program is None or not flat.exposed:
        return
    bad: set[tuple[str, str, str]] = set()
    seen: set[str] = set()
    for name, kind, k, fid, port in flat.exposed:
        known = state.ports.get(fid)
        if known is None:
            continue  # the inner node is broken and reported already
        have = known[0] if kind == "inputs" else known[1]
        if port in have:
            continue
        bad.add((kind, fid, port))
        path = f"subgraphs.{name}.{kind}[{k}].port"
        if path in seen:
            continue
        seen.add(path)
        node = state.node_by_id[fid]
        hint = difflib.get_close_matches(port, list(have), n=1)
        more = f"; did you mean '{hint[0]}'?" if hint else f" (it has: {', '.join(have) or 'none'})"
        state.errors.append(
            Issue(
                code="unknown_port",
                node=fid,
                port=port,
                path=path,
                message=f"subgraph '{name}' exposes '{fid.rsplit('/', 1)[1]}.{port}', but block "
                f"'{node.type}' has no {kind[:-1]} '{port}'{more}",
            )
        )
    if not bad:
        return
    keep = [
        (e, i)
        for e, i in zip(program.edges, state.doc_index["edges"])
        if ("outputs", e.from_.node, e.from_.port) not in bad and ("inputs", e.to.node, e.to.port) not in bad
    ]
    state.program = program.model_copy(update={"edges": [e for e, _ in keep]})
    state.doc_index["edges"] = [i for _, i in keep]
