"""Subgraphs: reusable groups of blocks, flattened away before a program is checked and planned.

A program may define subgraphs (`Program.subgraphs`, by name) and use them through nodes of type
`subgraph` (`params: {"subgraph": NAME}`). A subgraph node's ports are the definition's exposed ports
(`inputs` / `outputs`, each an inner node's port under an outer name), with the inner ports' types.

Before the checks run, `flatten` replaces every subgraph node by a copy of its definition's nodes,
their ids prefixed with the instance's id (`idle` + `breathe` -> `idle/breathe`, nested:
`a/b/breathe`), and rewires the edges into and out of the instance to the inner ports it exposes.
The flat program is what the checks, the plan and the APU see, so live values, cook times and
parameter changes address inner blocks by these ids; the document keeps its subgraphs (round trips).

Every issue about an inner node names the flat id (`idle/breathe`), and its `path` points into the
definition (`subgraphs.idle.nodes[2].params.amplitude`). Problems of the subgraph structure itself:

- `unknown_subgraph`: a subgraph node names no definition (or does not name one),
- `subgraph_cycle`: a definition contains itself (directly or through others); the cycle is named,
- `unknown_exposed_port`: a definition exposes a port of a node it does not have, or an edge uses a
  port the subgraph node does not expose,
- `unknown_port`: an exposed port names a port its inner node does not have (`check_exposed`).
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from typing import Any

from backend.graph.issues import Issue
from backend.graph.schema import (
    SUBGRAPH_PARAM,
    SUBGRAPH_TYPE,
    Edge,
    Endpoint,
    ExposedPort,
    Node,
    Program,
    Subgraph,
)

VIRTUAL = 1_000_000  # flat nodes/edges from inside subgraphs get document indices from here on
_PLACE = re.compile(r"\b(nodes|edges)\[(\d+)\]")


@dataclass
class Exposed:
    """Where an instance's ports lead in the flat graph: outer name -> (flat node id, port)."""

    inputs: dict[str, tuple[str, str]] = field(default_factory=dict)
    outputs: dict[str, tuple[str, str]] = field(default_factory=dict)


@dataclass
class Flat:
    """A flattened program and how to find its parts in the document."""

    program: Program
    node_index: list[int]  # document index (or virtual index) of each flat node
    edge_index: list[int]
    places: dict[tuple[str, int], str] = field(default_factory=dict)  # ("nodes", virtual) -> document path
    broken: dict[str, int] = field(default_factory=dict)  # unresolvable subgraph nodes (flat id -> index)
    instances: dict[str, tuple[str, Exposed]] = field(
        default_factory=dict
    )  # flat instance id -> (name, ports)
    # exposed ports to check once the inner blocks' ports are known: (definition, kind, k, flat node, port)
    exposed: list[tuple[str, str, int, str, str]] = field(default_factory=list)
    inner_of: dict[str, tuple[str, str]] = field(default_factory=dict)  # flat id -> (definition, inner id)

    def relocate(self, issue: Issue) -> Issue:
        """The issue with `nodes[i]` / `edges[i]` of inner parts replaced by their place in the document."""

        def sub(m: re.Match[str]) -> str:
            return self.places.get((m.group(1), int(m.group(2))), m.group(0))

        path = _PLACE.sub(sub, issue.path) if issue.path else issue.path
        message = _PLACE.sub(sub, issue.message)
        if path == issue.path and message == issue.message:
            return issue
        return issue.model_copy(update={"path": path, "message": message})


def uses_subgraphs(program: Program) -> bool:
    return bool(program.subgraphs) or any(n.type == SUBGRAPH_TYPE for n in program.nodes)


def flatten(program: Program, node_index: list[int], edge_index: list[int], errors: list[Issue]) -> Flat:
    """The program with every subgraph node replaced by its definition's blocks (see the module doc).

    `node_index` / `edge_index`: the document index of each node / edge of `program` (malformed ones
    are left out by the reader). Problems are appended to `errors`, each reported once.
    """
    flattener = _Flattener(program, errors)
    flattener.expand("", program.nodes, program.edges, node_index, edge_index, "", ())
    flat = flattener.flat
    flat.program = program.model_copy(
        update={"nodes": flattener.nodes, "edges": flattener.edges, "subgraphs": None}
    )
    return flat


class _Flattener:
    """One `flatten` under way: the definitions, the flat nodes and edges gathered so far, and the issues
    reported (each once)."""

    def __init__(self, program: Program, errors: list[Issue]):
        self.defs = program.subgraphs or {}
        self.flat = Flat(program=program, node_index=[], edge_index=[])
        self.nodes: list[Node] = []
        self.edges: list[Edge] = []
        self.errors = errors
        self.seen: set[tuple[str, str]] = set()
        self.counter = VIRTUAL

    def report(self, issue: Issue) -> None:
        key = (issue.code, issue.path or issue.message)
        if key not in self.seen:
            self.seen.add(key)
            self.errors.append(issue)

    def virtual(self, kind: str, place: str) -> int:
        """A new virtual document index for an inner node or edge, at `place` in the document."""
        self.counter += 1
        self.flat.places[(kind, self.counter)] = place
        return self.counter

    def expand(
        self,
        where: str,
        parts_nodes: list[Node],
        parts_edges: list[Edge],
        n_index: list[int] | None,
        e_index: list[int] | None,
        prefix: str,
        stack: tuple[str, ...],
    ) -> dict[str, Exposed]:
        """Add the flat nodes and edges of one graph level; returns the instances' port maps."""
        ports: dict[str, Exposed] = {}
        local = {n.id for n in parts_nodes}
        for k, node in enumerate(parts_nodes):
            here = f"{where}nodes[{k}]"
            idx = n_index[k] if n_index is not None else self.virtual("nodes", here)
            self.add_node(node, prefix + node.id, here, idx, prefix, stack, ports)
        for k, edge in enumerate(parts_edges):
            here = f"{where}edges[{k}]"
            src = _end(edge.from_, "outputs", ports, local, prefix, here + ".from", self.report)
            dst = _end(edge.to, "inputs", ports, local, prefix, here + ".to", self.report)
            if src is None or dst is None:
                continue
            idx = e_index[k] if e_index is not None else self.virtual("edges", here)
            if prefix or src != edge.from_ or dst != edge.to:
                edge = Edge(**{"from": src, "to": dst})
            self.edges.append(edge)
            self.flat.edge_index.append(idx)
        return ports

    def add_node(
        self,
        node: Node,
        fid: str,
        here: str,
        idx: int,
        prefix: str,
        stack: tuple[str, ...],
        ports: dict[str, Exposed],
    ) -> None:
        """Add one node of a level under its flat id `fid`: a block as it is, a subgraph node as its
        definition's blocks (its port map goes to `ports`); a broken one is reported and left out."""
        flat = self.flat
        if "/" in node.id and (stack or node.type == SUBGRAPH_TYPE):
            self.report(
                Issue(
                    code="schema",
                    node=fid,
                    path=f"{here}.id",
                    message=f"'{node.id}': the id of a subgraph node or of a block inside a subgraph "
                    f"cannot contain '/' (it separates the parts of inner ids)",
                )
            )
            flat.broken[fid] = idx
            return
        if stack:
            flat.inner_of[fid] = (stack[-1], node.id)
        if node.type != SUBGRAPH_TYPE:
            self.nodes.append(node.model_copy(update={"id": fid}) if prefix else node)
            flat.node_index.append(idx)
            return
        name = self.definition_of(node, fid, here, stack)
        if name is None:
            flat.broken[fid] = idx
            return
        ports[node.id] = self.instance(name, self.defs[name], fid, stack)
        flat.instances[fid] = (name, ports[node.id])

    def definition_of(self, node: Node, fid: str, here: str, stack: tuple[str, ...]) -> str | None:
        """The name of the definition a subgraph node uses, or None (reported) when it names none or one
        that contains itself; a parameter other than the name is reported too."""
        name = node.params.get(SUBGRAPH_PARAM)
        extra = sorted(set(node.params) - {SUBGRAPH_PARAM})
        if extra:
            self.report(
                Issue(
                    code="unknown_param",
                    node=fid,
                    port=extra[0],
                    path=f"{here}.params.{extra[0]}",
                    message=f"subgraph node '{fid}' has parameter '{extra[0]}'; a subgraph node has "
                    f"only '{SUBGRAPH_PARAM}' (its inner blocks carry their own parameters)",
                )
            )
        if not isinstance(name, str) or name not in self.defs:
            known = sorted(self.defs)
            hint = difflib.get_close_matches(name, known, n=1) if isinstance(name, str) else []
            what = f"'{name}', which is not defined" if isinstance(name, str) else "no subgraph"
            extra_hint = (
                f"; did you mean '{hint[0]}'?" if hint else f" (defined: {', '.join(known) or 'none'})"
            )
            self.report(
                Issue(
                    code="unknown_subgraph",
                    node=fid,
                    port=SUBGRAPH_PARAM,
                    path=f"{here}.params.{SUBGRAPH_PARAM}",
                    message=f"subgraph node '{fid}' names {what} in the program's subgraphs{extra_hint}",
                )
            )
            return None
        if name in stack:
            cycle = " → ".join((*stack[stack.index(name) :], name))
            self.report(
                Issue(
                    code="subgraph_cycle",
                    node=fid,
                    port=SUBGRAPH_PARAM,
                    path=f"{here}.params.{SUBGRAPH_PARAM}",
                    message=f"subgraph '{name}' contains itself: {cycle}",
                )
            )
            return None
        return name

    def instance(self, name: str, sub: Subgraph, fid: str, stack: tuple[str, ...]) -> Exposed:
        """Add the blocks of one instance `fid` of definition `name`; returns where its ports lead."""
        inner = self.expand(f"subgraphs.{name}.", sub.nodes, sub.edges, None, None, fid + "/", (*stack, name))
        ids = {n.id for n in sub.nodes}
        out = Exposed()
        for kind, listed, target in (
            ("inputs", sub.inputs, out.inputs),
            ("outputs", sub.outputs, out.outputs),
        ):
            for k, p in enumerate(listed):
                lead = self.exposed_lead(name, kind, k, p, fid, ids, inner)
                if lead is not None:
                    target[p.name] = lead
        return out

    def exposed_lead(
        self,
        name: str,
        kind: str,
        k: int,
        p: ExposedPort,
        fid: str,
        ids: set[str],
        inner: dict[str, Exposed],
    ) -> tuple[str, str] | None:
        """Where exposed port `p` (the k-th of `kind` of definition `name`) leads in instance `fid`: an
        inner block's port, or a nested instance's lead; None when it is broken (reported, or its inner
        node is)."""
        here = f"subgraphs.{name}.{kind}[{k}]"
        if p.node not in ids:
            hint = difflib.get_close_matches(p.node, sorted(ids), n=1)
            more = f"; did you mean '{hint[0]}'?" if hint else ""
            self.report(
                Issue(
                    code="unknown_exposed_port",
                    node=fid,
                    port=p.name,
                    path=f"{here}.node",
                    message=f"subgraph '{name}' exposes {kind[:-1]} '{p.name}' as '{p.node}.{p.port}', "
                    f"but it has no node '{p.node}'{more}",
                )
            )
            return None
        if p.node in inner:  # a nested subgraph node: follow its own exposed port
            deeper = getattr(inner[p.node], kind).get(p.port)
            if deeper is None:
                have = sorted(getattr(inner[p.node], kind))
                self.report(
                    Issue(
                        code="unknown_exposed_port",
                        node=f"{fid}/{p.node}",
                        port=p.port,
                        path=f"{here}.port",
                        message=f"subgraph '{name}' exposes {kind[:-1]} '{p.name}' as "
                        f"'{p.node}.{p.port}', but subgraph node '{p.node}' has no {kind[:-1]} "
                        f"'{p.port}' (it has: {', '.join(have) or 'none'})",
                    )
                )
            return deeper
        if f"{fid}/{p.node}" in self.flat.broken:
            return None
        self.flat.exposed.append((name, kind, k, f"{fid}/{p.node}", p.port))
        return (f"{fid}/{p.node}", p.port)


def _end(
    end: Endpoint, kind: str, ports: dict[str, Exposed], local: set[str], prefix: str, here: str, report: Any
) -> Endpoint | None:
    """The flat endpoint of one end of an edge (None: reported, the edge is left out)."""
    if end.node not in ports:
        return Endpoint(node=prefix + end.node, port=end.port) if prefix else end
    lead = getattr(ports[end.node], kind).get(end.port)
    if lead is None:
        have = sorted(getattr(ports[end.node], kind))
        report(
            Issue(
                code="unknown_exposed_port",
                node=prefix + end.node,
                port=end.port,
                path=f"{here}.port",
                message=f"subgraph node '{prefix + end.node}' has no {kind[:-1]} '{end.port}' "
                f"(it exposes: {', '.join(have) or 'none'})",
            )
        )
        return None
    return Endpoint(node=lead[0], port=lead[1])


def inner_definition_node(program: Program, flat_id: str) -> Node | None:
    """The definition's node behind a flat id `a/b/c` (None if there is no such inner node)."""
    parts = flat_id.split("/")
    nodes = program.nodes
    defs = program.subgraphs or {}
    for depth, part in enumerate(parts):
        node = next((n for n in nodes if n.id == part), None)
        if node is None:
            return None
        if depth == len(parts) - 1:
            return node
        name = node.params.get(SUBGRAPH_PARAM) if node.type == SUBGRAPH_TYPE else None
        sub = defs.get(name) if isinstance(name, str) else None
        if sub is None:
            return None
        nodes = sub.nodes
    return None
