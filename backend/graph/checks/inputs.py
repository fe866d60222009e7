"""Exposed inputs: each declaration on its own (`duplicate_input`, `invalid_input`) and, last, the
inputs no node reads (`unused_input`). Nodes that read inputs check them through `NodeCheck.read_input`."""

from __future__ import annotations

from backend.graph.checks.state import CheckState
from backend.graph.issues import Issue


def check_declarations(state: CheckState) -> None:
    assert state.program is not None and state.doc is not None
    for k, inp in enumerate(state.program.inputs):
        i = state.doc_index["inputs"][k]
        if inp.name in state.declared:
            state.errors.append(
                Issue(
                    code="duplicate_input",
                    port=inp.name,
                    path=f"inputs[{i}].name",
                    message=f"exposed input '{inp.name}' is declared twice; names must be unique",
                )
            )
            continue
        try:
            inp.coerce(inp.default)
        except ValueError as exc:
            state.errors.append(
                Issue(
                    code="invalid_input",
                    port=inp.name,
                    path=f"inputs[{i}].default",
                    message=f"the default of exposed {exc}",
                )
            )
        state.declared[inp.name] = inp
    # Inputs whose declaration is malformed were reported as schema errors; nodes reading them
    # should not add unknown_exposed_input on top.
    raw = state.doc.get("inputs")
    if not isinstance(raw, list):
        raw = []
    named = {item["name"] for item in raw if isinstance(item, dict) and isinstance(item.get("name"), str)}
    state.malformed_inputs = named - set(state.declared)


def check_unused(state: CheckState) -> None:
    assert state.program is not None
    for k, inp in enumerate(state.program.inputs):
        i = state.doc_index["inputs"][k]
        if inp.name not in state.read_inputs:
            state.warnings.append(
                Issue(
                    code="unused_input",
                    port=inp.name,
                    path=f"inputs[{i}]",
                    message=f"exposed input '{inp.name}' is not read by any 'input' node",
                )
            )
