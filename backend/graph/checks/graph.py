"""The graph as a whole: loops (`cycle`), exactly one output (`no_output`, `multiple_outputs`), the
APU level the output needs (`level_too_high`) and nodes that feed nothing (`unconnected_node`).

The output is the node whose block has `Role.output`; the level follows from the roles of the blocks
feeding it (`backend.engine.apu.required_level`). No block type is named here.
"""

from __future__ import annotations

from collections import defaultdict

from backend.engine.apu import required_level
from backend.engine.blocks.base import Role
from backend.graph.checks.state import CheckState
from backend.graph.issues import Issue


def check_cycles(state: CheckState) -> None:
    assert state.program is not None
    # The graph's nodes: each id once, as its first (kept) node in document order.
    state.ids = [n.id for n in state.program.nodes if state.node_by_id.get(n.id) is n]
    for loop in _cycles(state.ids, state.graph):
        closing = state.edge_at.get((loop[-1], loop[0]))
        state.errors.append(
            Issue(
                code="cycle",
                node=loop[0],
                port=closing[1] if closing else None,
                path=f"edges[{closing[0]}]" if closing else None,
                message="nodes " + " -> ".join([*loop, loop[0]]) + " form a loop; frames and "
                "signals must flow one way, from sources to the output",
            )
        )

    return None


def _cycles(ids: list[str], graph: dict[str, set[str]]) -> list[list[str]]:
    """The cycles of the graph among `ids`: one node path per strongly connected loop, in doc order."""
    pos = {n: k for k, n in enumerate(ids)}
    remaining = set(ids)
    # Peel off nodes with no incoming or no outgoing edge inside the remainder: they are on no cycle.
    changed = True
    while changed:
        changed = False
        for n in list(remaining):
            has_out = any(d in remaining for d in graph.get(n, ()))
            has_in = any(n in graph.get(s, ()) for s in remaining)
            if not has_out or not has_in:
                remaining.discard(n)
                changed = True
    loops = []
    while remaining:
        start = min(remaining, key=pos.__getitem__)
        # Breadth-first search for the shortest way back to `start`.
        parent: dict[str, str] = {}
        frontier = [start]
        seen = {start}
        found = None
        while frontier and found is None:
            nxt = []
            for n in frontier:
                for d in sorted(graph.get(n, ()), key=lambda x: pos.get(x, 0)):
                    if d == start:
                        found = n
                        break
                    if d in remaining and d not in seen:
                        seen.add(d)
                        parent[d] = n
                        nxt.append(d)
                if found is not None:
                    break
            frontier = nxt
        if found is None:
            remaining.discard(start)
            continue
        path = [found]
        while path[-1] != start:
            path.append(parent[path[-1]])
        loop = list(reversed(path))
        loops.append(loop)
        # Drop everything on a loop with `start` (its strongly connected component).
        reach = _reach(start, graph, remaining)
        back = {n for n in remaining if start in _reach(n, graph, remaining)}
        remaining -= (reach & back) | {start}
    return loops


def _reach(start: str, graph: dict[str, set[str]], within: set[str]) -> set[str]:
    seen: set[str] = set()
    stack = [start]
    while stack:
        n = stack.pop()
        for d in graph.get(n, ()):
            if d in within and d not in seen:
                seen.add(d)
                stack.append(d)
    return seen


def check_output(state: CheckState) -> None:
    state.outputs = [n for n in state.ids if _role(state, n) is Role.output]
    outputs = state.outputs
    if not outputs:
        state.errors.append(
            Issue(
                code="no_output",
                path="nodes",
                message="the program has no 'output' node; add one and connect the final frame "
                "to its 'in' input",
            )
        )
    elif len(outputs) > 1:
        state.errors.append(
            Issue(
                code="multiple_outputs",
                node=outputs[1],
                path=f"nodes[{state.node_index[outputs[1]]}]",
                message=f"the program has {len(outputs)} output nodes ({', '.join(outputs)}); "
                f"exactly one is allowed",
            )
        )


def check_level(state: CheckState) -> None:
    """The level the blocks feeding the one output need, against the program's and engine's limits."""
    assert state.program is not None
    if len(state.outputs) != 1:
        return
    upstream = _upstream(state.outputs[0], state.graph)
    roles = [(n, _role(state, n)) for n in state.ids if n in upstream]
    frame = [(n, r) for n, r in roles if r is not None and r not in (Role.signal, Role.output)]
    state.level = level = required_level([r for _, r in frame], len(frame))
    program_max = state.program.max_level
    if level > min(program_max, state.max_level):
        culprit = {3: Role.stage2, 2: Role.mixer}.get(level)
        cause = (
            next((n for n, r in frame if r is culprit), None)
            if culprit
            else (frame[1][0] if len(frame) > 1 else None)
        )
        why = {3: "it post-processes in stage 2", 2: "it mixes layers", 1: "it chains blocks"}[level]
        program_bound = program_max < state.max_level
        which = (
            f"the program's max_level ({program_max})"
            if program_bound
            else f"this engine's maximum ({state.max_level})"
        )
        state.errors.append(
            Issue(
                code="level_too_high",
                node=cause,
                path="max_level" if program_bound or cause is None else f"nodes[{state.node_index[cause]}]",
                message=f"the program needs APU level {level} ({why}"
                f"{f', node {cause!r}' if cause else ''}), above {which}",
            )
        )
    for n in state.ids:
        if n not in upstream:
            state.warnings.append(
                Issue(
                    code="unconnected_node",
                    node=n,
                    path=f"nodes[{state.node_index[n]}]",
                    message=f"node '{n}' ({state.node_by_id[n].type}) does not feed the "
                    f"output, so it has no effect",
                )
            )


def _role(state: CheckState, node_id: str) -> Role | None:
    cls = state.block_class(node_id)
    return cls.role if cls is not None else None


def _upstream(output: str, graph: dict[str, set[str]]) -> set[str]:
    """The output and every node with a path to it."""
    reverse: dict[str, set[str]] = defaultdict(set)
    for s, ds in graph.items():
        for d in ds:
            reverse[d].add(s)
    seen: set[str] = set()
    stack = [output]
    while stack:
        n = stack.pop()
        if n in seen:
            continue
        seen.add(n)
        stack.extend(reverse[n])
    return seen
