"""Reading the document: JSON text, the format version, and the shape of every field.

Parsing is lenient: a broken node, edge or input is reported (`schema`) and left out, a bad top-level
field is reported and dropped, and the rest of the graph is still checked.
"""

from __future__ import annotations

import json
from typing import Any

from pydantic import ValidationError
from pydantic_core import ErrorDetails

from backend.graph.checks.state import CheckState
from backend.graph.checks.text import loc, phrase, short
from backend.graph.issues import Issue
from backend.graph.schema import FORMAT, Edge, ExposedInput, Node, Program
from backend.graph.subgraphs import flatten, uses_subgraphs


def parse_document(source: Any, errors: list[Issue]) -> dict[str, Any] | None:
    """The JSON object of a program given as text, bytes, a dict or a Program (None: reported)."""
    if isinstance(source, Program):
        return source.to_json_dict()
    if isinstance(source, (bytes, bytearray)):
        source = bytes(source).decode("utf-8-sig", errors="replace")
    if isinstance(source, str):
        try:
            source = json.loads(source.lstrip("\ufeff"))
        except json.JSONDecodeError as exc:
            errors.append(
                Issue(
                    code="malformed_json",
                    line=exc.lineno,
                    column=exc.colno,
                    message=f"the file is not valid JSON: {exc.msg} at line {exc.lineno}, column {exc.colno}",
                )
            )
            return None
        except RecursionError:
            errors.append(Issue(code="malformed_json", message="the JSON is nested too deeply to read"))
            return None
    if not isinstance(source, dict):
        kind = {list: "a list", str: "a string", type(None): "null"}.get(type(source), type(source).__name__)
        errors.append(
            Issue(
                code="schema",
                message=f'a program is a JSON object ({{"format": "{FORMAT}", '
                f'"nodes": [...], ...}}), but this document is {kind}',
            )
        )
        return None
    return source


def _schema_message(path: str, err: ErrorDetails) -> str:
    kind = err.get("type", "")
    if kind == "missing":
        return f"{path} is required but missing"
    if kind == "extra_forbidden":
        return f"{path} is not a field of the program format"
    return f"{path}: {phrase(err)} (got {short(err.get('input'))})"


def parse_program(
    doc: dict[str, Any], errors: list[Issue]
) -> tuple[Program | None, dict[str, int], dict[str, list[int]]]:
    """Parse leniently: a broken node, edge or input is reported and left out, the rest goes on.

    Returns the program, the ids (and indices) of nodes left out because their entry is malformed,
    and for each of nodes/edges/inputs the document index of every item kept (for error paths).
    """
    broken: dict[str, int] = {}
    where: dict[str, list[int]] = {"nodes": [], "edges": [], "inputs": []}
    if "format" not in doc:
        errors.append(
            Issue(
                code="wrong_format",
                path="format",
                message=f'the document has no \'format\' field; add "format": "{FORMAT}"',
            )
        )
        return None, broken, where
    fmt = doc.get("format")
    if fmt != FORMAT:
        newer = isinstance(fmt, str) and fmt.startswith("nutty-program/")
        hint = " (written for another version of Nutty)" if newer else ""
        errors.append(
            Issue(
                code="wrong_format",
                path="format",
                message=f"format is {short(fmt)}{hint}; this engine reads '{FORMAT}'",
            )
        )
        return None, broken, where
    parts: dict[str, list[Any]] = {"nodes": [], "edges": [], "inputs": []}
    models = {"nodes": Node, "edges": Edge, "inputs": ExposedInput}
    for key, model in models.items():
        raw = doc.get(key, [])
        if not isinstance(raw, list):
            errors.append(
                Issue(code="schema", path=key, message=f"'{key}' must be a list, got {type(raw).__name__}")
            )
            continue
        for i, item in enumerate(raw):
            try:
                parts[key].append(model.model_validate(item))
                where[key].append(i)
            except ValidationError as exc:
                node_id = item.get("id") if key == "nodes" and isinstance(item, dict) else None
                node_id = node_id if isinstance(node_id, str) else None
                if node_id:
                    broken.setdefault(node_id, i)
                name = item.get("name") if key == "inputs" and isinstance(item, dict) else None
                for err in exc.errors():
                    path = loc((key, i, *err["loc"]))
                    code = "invalid_input" if key == "inputs" and err["type"] == "value_error" else "schema"
                    errors.append(
                        Issue(
                            code=code,
                            node=node_id,
                            port=name if isinstance(name, str) else None,
                            path=path,
                            message=_schema_message(path, err),
                        )
                    )
    rest = {k: v for k, v in doc.items() if k not in models}
    for _ in range(2):  # report bad top-level fields, drop them, and go on with the graph
        try:
            program = Program.model_validate({**rest, **{k: [] for k in models}}).model_copy(update=parts)
            return program, broken, where
        except ValidationError as exc:
            for err in exc.errors():
                path = loc(tuple(err["loc"]))
                errors.append(Issue(code="schema", path=path, message=_schema_message(path, err)))
                field = err["loc"][0] if err["loc"] else None
                if isinstance(field, str):  # a top-level field (an index only inside a list)
                    rest.pop(field, None)
    return None, broken, where


def read_document(state: CheckState) -> None:
    """The first pass: parse `state.source` into `state.program` (None when nothing can be checked)."""
    state.doc = parse_document(state.source, state.errors)
    if state.doc is not None:
        state.program, state.broken, state.doc_index = parse_program(state.doc, state.errors)
    state.document = state.program
    if state.program is not None and uses_subgraphs(state.program):
        # The checks see the flat program: subgraph nodes replaced by their inner blocks.
        state.flat = flatten(state.program, state.doc_index["nodes"], state.doc_index["edges"], state.errors)
        state.program = state.flat.program
        state.doc_index = {**state.doc_index, "nodes": state.flat.node_index, "edges": state.flat.edge_index}
        state.broken = {**state.broken, **state.flat.broken}
