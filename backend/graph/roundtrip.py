"""Graph -> compiled program -> graph: rebuild the document a running APU was compiled from.

The APU keeps its source Program. `apu_to_program` returns that document with every node's
parameters as the block holds them *now* (after live `update_params` changes), and its edges as the
APU actually wires them, so saving what is running never loses a tweak, an editor position or an
exposed input. Untouched parameters keep the spelling of the original document (defaults stay
omitted), so an unchanged program comes back equal to what was loaded.
"""

from __future__ import annotations

import json
from typing import Any

from backend.engine.apu import APU
from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block
from backend.graph.schema import SUBGRAPH_TYPE, Edge, Endpoint, Node, Program
from backend.graph.subgraphs import flatten, uses_subgraphs


class RoundTripError(ValueError):
    """The APU carries no source document (it was not built by `compile_program`)."""


def _live_params(node: Node, block: Block | None) -> dict[str, Any]:
    cls = BLOCKS.get(node.type)
    if cls is None or block is None:
        return dict(node.params)
    try:
        loaded = cls.Params.model_validate(node.params)
    except ValueError:
        loaded = None
    if loaded == block.params:
        return dict(node.params)  # untouched: keep the author's spelling
    return block.params.model_dump(mode="json", exclude_unset=True)


def _with_subgraphs(apu: APU, source: Program) -> Program:
    """The document of a program that uses subgraphs: top-level nodes with their live parameters, and
    each definition's inner nodes with the live parameters of their blocks when every instance of the
    definition agrees (a definition is shared; one instance's tweak alone cannot be written back)."""
    flat = flatten(source, list(range(len(source.nodes))), list(range(len(source.edges))), [])
    nodes = []
    for node in source.nodes:
        block = apu.block(node.id) if node.id in apu.index and node.type != SUBGRAPH_TYPE else None
        nodes.append(
            node.model_copy(update={"params": _live_params(node, block), "ui": dict(node.ui)}, deep=True)
        )
    blocks: dict[tuple[str, str], list[Any]] = {}
    for fid, (name, inner) in flat.inner_of.items():
        if fid in apu.index:
            blocks.setdefault((name, inner), []).append(apu.block(fid))
    subgraphs = {}
    for name, sub in (source.subgraphs or {}).items():
        inner_nodes = []
        for node in sub.nodes:
            found = blocks.get((name, node.id), [])
            live = [_live_params(node, b) for b in found]
            params = live[0] if live and all(p == live[0] for p in live) else dict(node.params)
            inner_nodes.append(node.model_copy(update={"params": params}, deep=True))
        subgraphs[name] = sub.model_copy(update={"nodes": inner_nodes}, deep=True)
    return source.model_copy(
        update={
            "nodes": nodes,
            "subgraphs": subgraphs,
            "edges": [e.model_copy(deep=True) for e in source.edges],
            "inputs": [i.model_copy(deep=True) for i in source.inputs],
        },
        deep=True,
    )


def apu_to_program(apu: APU) -> Program:
    """The program document of a compiled (possibly running and live-tuned) APU."""
    source = apu.source
    if not isinstance(source, Program):
        raise RoundTripError("this APU has no source program to rebuild")
    if uses_subgraphs(source):
        return _with_subgraphs(apu, source)
    nodes = []
    for node in source.nodes:
        block = apu.block(node.id) if node.id in apu.index else None
        nodes.append(
            node.model_copy(update={"params": _live_params(node, block), "ui": dict(node.ui)}, deep=True)
        )
    # Edges: as wired in the APU, in the order of the source document.
    wired = {
        (apu.steps[w.src].node_id, w.src_port, step.node_id, w.port) for step in apu.steps for w in step.wires
    }
    edges = [e.model_copy(deep=True) for e in source.edges if e.key() in wired]
    known = {e.key() for e in edges}
    for key in sorted(wired - known):
        edges.append(
            Edge(**{"from": Endpoint(node=key[0], port=key[1]), "to": Endpoint(node=key[2], port=key[3])})
        )
    return source.model_copy(
        update={"nodes": nodes, "edges": edges, "inputs": [i.model_copy(deep=True) for i in source.inputs]},
        deep=True,
    )


def apu_to_json(apu: APU) -> str:
    """`apu_to_program` as JSON text laid out for people (what saving a running program writes)."""
    return format_json(apu_to_program(apu).to_json_dict())


def format_json(data: Any, width: int = 120) -> str:
    """JSON for people: indented, but small objects and lists (ui, params, endpoints) on one line."""

    def fmt(value: Any, indent: int) -> str:
        flat = json.dumps(value, ensure_ascii=False)
        if not isinstance(value, (dict, list)) or not value or len(flat) + indent <= width:
            return flat
        pad, inner = " " * indent, " " * (indent + 2)
        if isinstance(value, dict):
            items = [
                f"{inner}{json.dumps(k, ensure_ascii=False)}: {fmt(v, indent + 2)}" for k, v in value.items()
            ]
            return "{\n" + ",\n".join(items) + "\n" + pad + "}"
        return "[\n" + ",\n".join(inner + fmt(v, indent + 2) for v in value) + "\n" + pad + "]"

    return fmt(data, 0) + "\n"
