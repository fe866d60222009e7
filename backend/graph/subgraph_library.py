"""A subgraph saved on its own in the robot's library, checked as the program checks would see it in a
program of one instance (kept apart from `backend.graph.subgraphs`, which the checks themselves use)."""

from __future__ import annotations

from typing import Any

from pydantic import ValidationError

from backend.engine.blocks.base import BlockContext
from backend.engine.embodiment import Embodiment
from backend.graph.checks import run_checks
from backend.graph.issues import Issue
from backend.graph.schema import Subgraph
from backend.graph.subgraphs import SUBGRAPH_PARAM, SUBGRAPH_TYPE


def standalone_issues(
    name: str, definition: Any, embodiment: Embodiment, ctx: BlockContext
) -> tuple[Subgraph | None, list[Issue]]:
    """Check a subgraph definition on its own (a library entry): its shape, then its blocks and inner
    wiring as the program checks see them in a program of one instance. Missing inputs at exposed
    ports and the lack of an `output` node are not errors here."""
    try:
        sub = Subgraph.model_validate(definition)
    except ValidationError as exc:
        return None, [
            Issue(
                code="schema",
                path=".".join(str(x) for x in e["loc"]) or None,
                message=f"{'.'.join(str(x) for x in e['loc']) or 'the definition'}: {e['msg']}",
            )
            for e in exc.errors()
        ]
    doc = {
        "format": "nutty-program/1",
        "name": name,
        "subgraphs": {name: sub.model_dump(mode="json", by_alias=True)},
        "nodes": [{"id": name, "type": SUBGRAPH_TYPE, "params": {SUBGRAPH_PARAM: name}}],
    }
    nested = [n.id for n in sub.nodes if n.type == SUBGRAPH_TYPE]
    if nested:
        return sub, [
            Issue(
                code="unknown_subgraph",
                node=f"{name}/{nested[0]}",
                port=SUBGRAPH_PARAM,
                path=f"nodes[{[n.id for n in sub.nodes].index(nested[0])}].params.{SUBGRAPH_PARAM}",
                message=f"a subgraph in the library is self-contained: it cannot use other subgraphs "
                f"(node '{nested[0]}' does); save the inner one separately",
            )
        ]
    state = run_checks(doc, embodiment, max_level=3, ctx=ctx)
    exposed_in = {(f"{name}/{p.node}", p.port) for p in sub.inputs}
    issues = [
        i
        for i in state.errors
        if i.code not in ("no_output", "level_too_high")
        and not (i.code == "missing_input" and (i.node, i.port) in exposed_in)
    ]
    return sub, issues
