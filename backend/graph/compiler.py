"""Validate an Animation Program against a robot and compile it into an APU, in one pass.

`compile_program` returns *every* error at once (ComfyUI-style), each with a machine-readable code,
the node id, the port or parameter it is about (`port`), its exact place in the document (`path`)
and a sentence for a person; plus warnings. A program with errors produces no APU, so loading is
atomic: nothing in a running engine changes.

`port` is an input/output port name for graph errors (edges, missing inputs) and the parameter path
relative to the node's `params` for parameter errors (`amplitude`, `dofs`, `layers[1].mask`); `path`
goes down to the offending element (`nodes[3].params.layers[1].mask[0]`).

One broken thing gives one error: a node whose type is unknown or whose parameters are invalid is
reported once, and edges touching it are checked only at their other end (no knock-on
`missing_input` or `unknown_node`).

The codes and what they mean are in ERROR_CODES and WARNING_CODES (and docs/program-format.md).
"""

from __future__ import annotations

import difflib
import json
import typing
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any, Iterator

from pydantic import BaseModel, Field, ValidationError

from backend.engine.apu import APU, MAX_LEVEL, Step, Wire, required_level
from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block, BlockContext, BlockParams, Port, PortType, Role, port_accepts
from backend.engine.embodiment import Embodiment
from backend.engine.selectors import SelectorError, select_dofs
from backend.graph.schema import FORMAT, Edge, ExposedInput, Node, Program

ERROR_CODES: dict[str, str] = {
    "malformed_json": "the text is not valid JSON (line and column given)",
    "wrong_format": "the `format` field is missing or names another version of the format",
    "schema": "a field of the document has the wrong shape (missing, wrong type, unexpected)",
    "duplicate_node": "two nodes share an id",
    "unknown_block_type": "a node's `type` is not a registered block",
    "unknown_param": "a node sets a parameter its block does not have",
    "invalid_param": "a parameter value is out of range or of the wrong type",
    "unknown_dof": "a DoF selector names a DoF the robot does not have (or is malformed)",
    "block_config": "the block rejects its parameters as a whole (e.g. an unknown posture)",
    "unknown_node": "an edge names a node that does not exist",
    "unknown_port": "an edge names a port its node does not have",
    "port_type_mismatch": "an edge joins ports of incompatible types",
    "multiple_edges": "more than one edge goes into the same input",
    "missing_input": "a required input has no edge",
    "cycle": "edges form a loop",
    "no_output": "the program has no `output` node",
    "multiple_outputs": "the program has more than one `output` node",
    "level_too_high": "the graph needs a higher APU level than the program or engine allows",
    "unknown_exposed_input": "an `input` node reads an exposed input the program does not declare",
    "duplicate_input": "two exposed inputs share a name",
    "invalid_input": "an exposed input's declaration is inconsistent (range, default)",
}
WARNING_CODES: dict[str, str] = {
    "unconnected_node": "a node does not feed the output",
    "zero_weight_layer": "a layer of a mixer has weight 0",
    "empty_layer": "a layer of a mixer has nothing connected",
    "unused_input": "an exposed input is read by no node",
}


class Issue(BaseModel):
    """One validation error or warning."""

    code: str
    node: str | None = None
    port: str | None = None
    message: str
    path: str | None = Field(None, description="JSON path in the document, e.g. nodes[2].params.amplitude")
    line: int | None = None
    column: int | None = None

    def render(self) -> str:
        """`[code] node.port: message` (with line and column for JSON errors)."""
        where = ".".join(x for x in (self.node, self.port) if x)
        at = ""
        if self.line is not None and f"line {self.line}" not in self.message:
            at = f" (line {self.line}, column {self.column})"
        return f"[{self.code}] {where + ': ' if where else ''}{self.message}{at}"


class ValidationReport(BaseModel):
    valid: bool
    level: int | None = None
    errors: list[Issue] = Field(default_factory=list)
    warnings: list[Issue] = Field(default_factory=list)


@dataclass
class CompileResult:
    report: ValidationReport
    apu: APU | None = None
    program: Program | None = None
    params: dict[str, BlockParams] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.apu is not None


class ProgramError(ValueError):
    """A program failed validation; `report` holds every error."""

    def __init__(self, report: ValidationReport):
        self.report = report
        first = report.errors[0] if report.errors else None
        more = f" (+{len(report.errors) - 1} more)" if len(report.errors) > 1 else ""
        super().__init__(f"{first.code}: {first.message}{more}" if first else "invalid program")


# --- document -------------------------------------------------------------------------------------


def _loc(loc: tuple[Any, ...] | list[Any]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _parse_document(source: Any, errors: list[Issue]) -> dict[str, Any] | None:
    if isinstance(source, Program):
        return source.to_json_dict()
    if isinstance(source, (bytes, bytearray)):
        source = bytes(source).decode("utf-8-sig", errors="replace")
    if isinstance(source, str):
        try:
            source = json.loads(source.lstrip("\ufeff"))
        except json.JSONDecodeError as exc:
            errors.append(Issue(code="malformed_json", line=exc.lineno, column=exc.colno,
                                message=f"the file is not valid JSON: {exc.msg} at line {exc.lineno}, "
                                        f"column {exc.colno}"))
            return None
        except RecursionError:
            errors.append(Issue(code="malformed_json", message="the JSON is nested too deeply to read"))
            return None
    if not isinstance(source, dict):
        kind = {list: "a list", str: "a string", type(None): "null"}.get(type(source), type(source).__name__)
        errors.append(Issue(code="schema", message=f"a program is a JSON object ({{\"format\": \"{FORMAT}\", "
                                                   f"\"nodes\": [...], ...}}), but this document is {kind}"))
        return None
    return source


def _schema_message(path: str, err: dict[str, Any]) -> str:
    kind = err.get("type", "")
    if kind == "missing":
        return f"{path} is required but missing"
    if kind == "extra_forbidden":
        return f"{path} is not a field of the program format"
    return f"{path}: {_phrase(err)} (got {_short(err.get('input'))})"


def _phrase(err: dict[str, Any]) -> str:
    kind, ctx = err.get("type", ""), err.get("ctx") or {}
    if kind == "less_than_equal":
        return f"must be at most {ctx.get('le')}"
    if kind == "greater_than_equal":
        return f"must be at least {ctx.get('ge')}"
    if kind == "less_than":
        return f"must be below {ctx.get('lt')}"
    if kind == "greater_than":
        return f"must be above {ctx.get('gt')}"
    if kind == "missing":
        return "is required"
    if kind == "literal_error":
        return f"must be one of {ctx.get('expected')}"
    msg = str(err.get("msg", "is invalid"))
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
    return msg[:1].lower() + msg[1:]


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _parse_program(doc: dict[str, Any], errors: list[Issue]
                   ) -> tuple[Program | None, dict[str, int], dict[str, list[int]]]:
    """Parse leniently: a broken node, edge or input is reported and left out, the rest goes on.

    Returns the program, the ids (and indices) of nodes left out because their entry is malformed,
    and for each of nodes/edges/inputs the document index of every item kept (for error paths).
    """
    broken: dict[str, int] = {}
    where: dict[str, list[int]] = {"nodes": [], "edges": [], "inputs": []}
    if "format" not in doc:
        errors.append(Issue(code="wrong_format", path="format",
                            message=f"the document has no 'format' field; add \"format\": \"{FORMAT}\""))
        return None, broken, where
    fmt = doc.get("format")
    if fmt != FORMAT:
        newer = isinstance(fmt, str) and fmt.startswith("nutty-program/")
        hint = " (written for another version of Nutty)" if newer else ""
        errors.append(Issue(code="wrong_format", path="format",
                            message=f"format is {_short(fmt)}{hint}; this engine reads '{FORMAT}'"))
        return None, broken, where
    parts: dict[str, list[Any]] = {"nodes": [], "edges": [], "inputs": []}
    models = {"nodes": Node, "edges": Edge, "inputs": ExposedInput}
    for key, model in models.items():
        raw = doc.get(key, [])
        if not isinstance(raw, list):
            errors.append(Issue(code="schema", path=key,
                                message=f"'{key}' must be a list, got {type(raw).__name__}"))
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
                    path = _loc((key, i, *err["loc"]))
                    code = "invalid_input" if key == "inputs" and err["type"] == "value_error" else "schema"
                    errors.append(Issue(code=code, node=node_id, port=name if isinstance(name, str) else None,
                                        path=path, message=_schema_message(path, err)))
    rest = {k: v for k, v in doc.items() if k not in models}
    for _ in range(2):  # report bad top-level fields, drop them, and go on with the graph
        try:
            program = Program.model_validate({**rest, **{k: [] for k in models}}).model_copy(update=parts)
            return program, broken, where
        except ValidationError as exc:
            for err in exc.errors():
                path = _loc(tuple(err["loc"]))
                errors.append(Issue(code="schema", path=path, message=_schema_message(path, err)))
                if err["loc"]:
                    rest.pop(err["loc"][0], None)
    return None, broken, where


# --- parameters -----------------------------------------------------------------------------------


def _submodel(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside an annotation such as `list[LayerSpec]` or `LayerSpec | None`."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _submodel(arg)
        if found is not None:
            return found
    return None


def _walk_loc(model: type[BaseModel], loc: tuple[Any, ...]) -> tuple[list[Any], type[BaseModel] | None, int]:
    """Follow a pydantic error location through (nested) parameter models.

    Returns the parameter path (field names and list indices of nested models), the model the path
    ends in (None past a plain field) and how many parts of `loc` it used.
    """
    parts: list[Any] = []
    cur: type[BaseModel] | None = model
    k = 0
    while k < len(loc) and cur is not None:
        name = loc[k]
        if not isinstance(name, str) or name not in cur.model_fields:
            break
        parts.append(name)
        k += 1
        sub = _submodel(cur.model_fields[name].annotation)
        if sub is None:
            cur = None
            break
        if k < len(loc) and isinstance(loc[k], int):
            parts.append(loc[k])
            k += 1
        cur = sub
    return parts, cur, k


def _params_errors(node: Node, index: int, cls: type[Block], exc: ValidationError) -> list[Issue]:
    out: list[Issue] = []
    grouped: dict[str, list[dict[str, Any]]] = {}
    for err in exc.errors():
        loc = tuple(err["loc"])
        parts, model, used = _walk_loc(cls.Params, loc)
        if err["type"] == "extra_forbidden":
            name = loc[used] if used < len(loc) else (loc[-1] if loc else "?")
            known = list((model or cls.Params).model_fields)
            hint = difflib.get_close_matches(str(name), known, n=1)
            extra = f"; did you mean '{hint[0]}'?" if hint else f" (it has: {', '.join(known)})"
            where = f"'{_loc(parts)}' " if parts else ""
            port = _loc([*parts, name])
            what = f"has no setting '{name}' in {where}" if parts else f"has no parameter '{name}'"
            out.append(Issue(code="unknown_param", node=node.id, port=port,
                             path=_loc((f"nodes[{index}].params", *parts, name)),
                             message=f"node '{node.id}' ({node.type}) {what.rstrip()}{extra}"))
            continue
        # Group the errors of one value (a union type reports one error per alternative).
        key = _loc(loc[: used + 1]) if loc else ""
        grouped.setdefault(key, []).append(err)
    for key, errs in grouped.items():
        loc = tuple(errs[0]["loc"])
        parts, _, used = _walk_loc(cls.Params, loc)
        port = _loc(parts) if parts else (str(loc[0]) if loc else None)
        got = errs[0].get("input")
        if len(errs) == 1:
            reason = _phrase(errs[0])
        else:
            reason = "has the wrong type (" + "; ".join(dict.fromkeys(_phrase(e) for e in errs)) + ")"
        label = _loc(loc[: used + 1]) if loc else "parameters"
        if errs[0]["type"] == "missing":
            message = f"node '{node.id}' ({node.type}) needs parameter '{label}'"
        else:
            message = f"node '{node.id}' ({node.type}): parameter '{label}' {reason}, got {_short(got)}"
        out.append(Issue(code="invalid_param", node=node.id, port=port,
                         path=_loc((f"nodes[{index}].params", *loc[: used + 1])), message=message))
    return out


def _widget(info: Any) -> str | None:
    extra = info.json_schema_extra
    return extra.get("x-widget") if isinstance(extra, dict) else None


def _dof_params(model: BaseModel, prefix: tuple[Any, ...] = ()
                ) -> Iterator[tuple[tuple[Any, ...], str, Any, BaseModel]]:
    """Every DoF-naming parameter of a parameter model, nested models included.

    Yields (location, widget, value, owning model) for fields marked `x-widget: dofs` (selector lists)
    or `x-widget: pose` (DoF name -> value).
    """
    for name, info in type(model).model_fields.items():
        value = getattr(model, name, None)
        widget = _widget(info)
        if widget in ("dofs", "pose"):
            yield (*prefix, name), widget, value, model
        elif isinstance(value, BaseModel):
            yield from _dof_params(value, (*prefix, name))
        elif isinstance(value, (list, tuple)):
            for j, item in enumerate(value):
                if isinstance(item, BaseModel):
                    yield from _dof_params(item, (*prefix, name, j))


def _dof_hint(emb: Embodiment, name: str) -> str:
    candidates = [d.name for d in emb.dofs] + list(getattr(emb, "channel_index", {}) or {})
    hint = difflib.get_close_matches(name.lstrip("!"), candidates, n=1)
    return f"; did you mean '{hint[0]}'?" if hint else ""


def _dof_errors(node: Node, index: int, params: BlockParams, emb: Embodiment) -> list[Issue]:
    """Check every DoF selector and pose key of a node against the robot, each with its exact path."""
    from backend.engine.blocks.core import pose_vector

    out: list[Issue] = []
    for loc, widget, value, owner in _dof_params(params):
        port = _loc(loc)
        owner_name = getattr(owner, "name", None) if owner is not params else None
        whose = f"{str(loc[0]).rstrip('s')} '{owner_name}' of " if isinstance(owner_name, str) else ""
        head = f"{whose}node '{node.id}' ({node.type}), parameter '{port}'"
        if widget == "dofs" and isinstance(value, (list, tuple)):
            for j, sel in enumerate(value):
                try:
                    select_dofs(emb, [sel])
                except SelectorError as exc:
                    out.append(Issue(code="unknown_dof", node=node.id, port=port,
                                     path=_loc((f"nodes[{index}].params", *loc, j)),
                                     message=f"{head}: {exc}{_dof_hint(emb, str(sel))}"))
        elif widget == "pose" and isinstance(value, dict):
            for name, v in value.items():
                path = _loc((f"nodes[{index}].params", *loc, name))
                try:
                    pose_vector(emb, {name: v})
                except SelectorError as exc:
                    out.append(Issue(code="unknown_dof", node=node.id, port=port, path=path,
                                     message=f"{head}: {exc}{_dof_hint(emb, str(name))}"))
                except (ValueError, TypeError) as exc:
                    out.append(Issue(code="invalid_param", node=node.id, port=port, path=path,
                                     message=f"{head}: {exc}"))
    return out


def _find_value(data: Any, target: str, loc: tuple[Any, ...] = ()) -> tuple[Any, ...] | None:
    """Where a string (e.g. a selector a block rejected) occurs in a parameter dump."""
    if data == target:
        return loc
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        if isinstance(data, dict) and key == target:
            return (*loc, key)
        found = _find_value(value, target, (*loc, key))
        if found is not None:
            return found
    return None


# --- graph helpers --------------------------------------------------------------------------------


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


def _ports_text(ports: dict[str, Port], kind: str) -> str:
    if not ports:
        return f"it has no {kind}s"
    return f"its {kind}s: " + ", ".join(f"{k} ({p.type.value})" for k, p in sorted(ports.items()))


# --- compile --------------------------------------------------------------------------------------


def compile_program(source: Any, embodiment: Embodiment, *, max_level: int = MAX_LEVEL,
                    ctx: BlockContext | None = None, rate: float = 100.0) -> CompileResult:
    """Validate `source` (JSON text, dict or Program) for `embodiment` and build its APU if valid.

    Never raises for a bad program: every problem is an Issue in the report.
    """
    errors: list[Issue] = []
    warnings: list[Issue] = []
    doc = _parse_document(source, errors)
    program, broken, doc_index = _parse_program(doc, errors) if doc is not None else (None, {}, {})
    if program is None:
        return CompileResult(ValidationReport(valid=False, errors=errors))
    ctx = ctx or BlockContext(embodiment=embodiment, rate=rate)

    # --- exposed inputs ---------------------------------------------------------------------------
    declared: dict[str, ExposedInput] = {}
    for k, inp in enumerate(program.inputs):
        i = doc_index["inputs"][k]
        if inp.name in declared:
            errors.append(Issue(code="duplicate_input", port=inp.name, path=f"inputs[{i}].name",
                                message=f"exposed input '{inp.name}' is declared twice; names must be unique"))
            continue
        try:
            inp.coerce(inp.default)
        except ValueError as exc:
            errors.append(Issue(code="invalid_input", port=inp.name, path=f"inputs[{i}].default",
                                message=f"the default of exposed {exc}"))
        declared[inp.name] = inp
    # Inputs whose declaration is malformed were reported as schema errors; nodes reading them
    # should not add unknown_exposed_input on top.
    raw_inputs = doc.get("inputs") if isinstance(doc.get("inputs"), list) else []
    malformed = {raw["name"] for raw in raw_inputs if isinstance(raw, dict) and isinstance(raw.get("name"), str)}
    malformed -= set(declared)

    # --- nodes --------------------------------------------------------------------------------------
    blocks: dict[str, Block] = {}
    params: dict[str, BlockParams] = {}
    ports: dict[str, tuple[dict[str, Port], dict[str, Port]] | None] = {}  # None: exists, ports unknown
    node_by_id: dict[str, Node] = {}
    node_index: dict[str, int] = {}
    for k, node in enumerate(program.nodes):
        i = doc_index["nodes"][k]
        if node.id in node_by_id or node.id in broken:
            first = node_index.get(node.id, broken.get(node.id))
            errors.append(Issue(code="duplicate_node", node=node.id, path=f"nodes[{i}].id",
                                message=f"node id '{node.id}' is used twice (nodes[{first}] "
                                        f"and nodes[{i}]); ids must be unique"))
            continue
        node_by_id[node.id] = node
        node_index[node.id] = i
        ports[node.id] = None
        cls = BLOCKS.get(node.type)
        if cls is None:
            hint = difflib.get_close_matches(node.type, list(BLOCKS), n=1)
            extra = f"; did you mean '{hint[0]}'?" if hint else f" (known: {', '.join(sorted(BLOCKS))})"
            errors.append(Issue(code="unknown_block_type", node=node.id, path=f"nodes[{i}].type",
                                message=f"node '{node.id}' has type '{node.type}', which is not a block{extra}"))
            continue
        try:
            p = cls.Params.model_validate(node.params)
        except ValidationError as exc:
            errors.extend(_params_errors(node, i, cls, exc))
            continue
        except Exception as exc:  # a block's own validator misbehaving must not crash validation
            errors.append(Issue(code="block_config", node=node.id, path=f"nodes[{i}].params",
                                message=f"node '{node.id}' ({node.type}): parameters rejected: {exc}"))
            continue
        params[node.id] = p
        try:
            ports[node.id] = cls.ports(p)
        except Exception as exc:
            errors.append(Issue(code="block_config", node=node.id, path=f"nodes[{i}].params",
                                message=f"node '{node.id}' ({node.type}): cannot derive its ports: {exc}"))
        if cls.type_name == "input":
            name, kind = getattr(p, "name", None), getattr(p, "type", None)
            if name not in declared and name not in malformed:
                hint = difflib.get_close_matches(str(name), list(declared), n=1)
                extra = (f"; did you mean '{hint[0]}'?" if hint else
                         f" (declared: {', '.join(sorted(declared)) or 'none'})")
                errors.append(Issue(code="unknown_exposed_input", node=node.id, port="name",
                                    path=f"nodes[{i}].params.name",
                                    message=f"node '{node.id}' reads exposed input '{name}', which the program "
                                            f"does not declare in 'inputs'{extra}"))
            elif name in declared and declared[name].type != kind:
                errors.append(Issue(code="port_type_mismatch", node=node.id, port="type",
                                    path=f"nodes[{i}].params.type",
                                    message=f"node '{node.id}' reads exposed input '{name}' as {kind}, but the "
                                            f"program declares it as {declared[name].type}"))
                ports[node.id] = None  # its output type is in doubt: do not check its edges as well
        dof_issues = _dof_errors(node, i, p, embodiment)
        errors.extend(dof_issues)
        if dof_issues:
            continue
        try:
            blocks[node.id] = cls(p, ctx, node.id)
        except SelectorError as exc:
            where = _find_value(p.model_dump(mode="json"), exc.selector) or ()
            parts = _walk_loc(cls.Params, where)[0] if where else []
            errors.append(Issue(code="unknown_dof", node=node.id, port=_loc(parts) if parts else None,
                                path=_loc((f"nodes[{i}].params", *where)),
                                message=f"node '{node.id}' ({node.type}): {exc}"))
        except Exception as exc:  # configure() says the parameters do not fit this robot
            errors.append(Issue(code="block_config", node=node.id, path=f"nodes[{i}].params",
                                message=f"node '{node.id}' ({node.type}) cannot be set up on robot "
                                        f"'{embodiment.name}': {exc}"))

    # --- edges --------------------------------------------------------------------------------------
    incoming: dict[tuple[str, str], tuple[int, Edge]] = {}
    graph: dict[str, set[str]] = defaultdict(set)  # node -> downstream nodes
    edge_at: dict[tuple[str, str], tuple[int, str]] = {}  # (src, dst) -> (edge index, dst port)
    good_edges: list[Edge] = []
    for k, edge in enumerate(program.edges):
        i = doc_index["edges"][k]
        src, dst = edge.from_, edge.to
        ok = True
        for end, role in ((src, "from"), (dst, "to")):
            if end.node not in node_by_id and end.node not in broken:
                hint = difflib.get_close_matches(end.node, list(node_by_id), n=1)
                extra = f"; did you mean '{hint[0]}'?" if hint else ""
                verb = "comes from" if role == "from" else "goes to"
                errors.append(Issue(code="unknown_node", node=end.node, port=end.port, path=f"edges[{i}].{role}.node",
                                    message=f"edge {src.node}.{src.port} -> {dst.node}.{dst.port} {verb} node "
                                            f"'{end.node}', which does not exist{extra}"))
                ok = False
        if not ok:
            continue
        src_ports, dst_ports = ports.get(src.node), ports.get(dst.node)
        out_ports = src_ports[1] if src_ports is not None else None
        in_ports = dst_ports[0] if dst_ports is not None else None
        if out_ports is not None and src.port not in out_ports:
            hint = difflib.get_close_matches(src.port, list(out_ports), n=1)
            extra = f"did you mean '{hint[0]}'? " if hint else ""
            errors.append(Issue(code="unknown_port", node=src.node, port=src.port, path=f"edges[{i}].from.port",
                                message=f"node '{src.node}' ({node_by_id[src.node].type}) has no output "
                                        f"'{src.port}'; {extra}{_ports_text(out_ports, 'output')}"))
            ok = False
        if in_ports is not None and dst.port not in in_ports:
            hint = difflib.get_close_matches(dst.port, list(in_ports), n=1)
            extra = f"did you mean '{hint[0]}'? " if hint else ""
            errors.append(Issue(code="unknown_port", node=dst.node, port=dst.port, path=f"edges[{i}].to.port",
                                message=f"node '{dst.node}' ({node_by_id[dst.node].type}) has no input "
                                        f"'{dst.port}'; {extra}{_ports_text(in_ports, 'input')}"))
            ok = False
        if not ok:
            continue
        if out_ports is not None and in_ports is not None:
            t_out, t_in = out_ports[src.port].type, in_ports[dst.port].type
            if not port_accepts(t_in, t_out):
                errors.append(Issue(code="port_type_mismatch", node=dst.node, port=dst.port, path=f"edges[{i}]",
                                    message=f"cannot connect output '{src.node}.{src.port}' ({t_out.value}) to "
                                            f"input '{dst.node}.{dst.port}' ({t_in.value})"))
                continue
        key = (dst.node, dst.port)
        if key in incoming:
            j, first = incoming[key]
            errors.append(Issue(code="multiple_edges", node=dst.node, port=dst.port, path=f"edges[{i}]",
                                message=f"input '{dst.node}.{dst.port}' already has an edge from "
                                        f"'{first.from_.node}.{first.from_.port}' (edges[{j}]); an input takes "
                                        f"one edge (use a layer mixer to combine frames)"))
            continue
        incoming[key] = (i, edge)
        graph[src.node].add(dst.node)
        edge_at.setdefault((src.node, dst.node), (i, dst.port))
        if out_ports is not None and in_ports is not None:
            good_edges.append(edge)

    for node_id, known in ports.items():
        if known is None:
            continue
        for pname, port in known[0].items():
            if port.required and (node_id, pname) not in incoming:
                errors.append(Issue(code="missing_input", node=node_id, port=pname,
                                    path=f"nodes[{node_index[node_id]}]",
                                    message=f"node '{node_id}' ({node_by_id[node_id].type}) needs an edge into "
                                            f"its '{pname}' input ({port.type.value})"))

    # --- cycles -------------------------------------------------------------------------------------
    ids = [n.id for n in program.nodes if n.id in node_by_id and node_by_id[n.id] is n]
    for loop in _cycles(ids, graph):
        closing = edge_at.get((loop[-1], loop[0]))
        errors.append(Issue(code="cycle", node=loop[0], port=closing[1] if closing else None,
                            path=f"edges[{closing[0]}]" if closing else None,
                            message="nodes " + " -> ".join([*loop, loop[0]]) + " form a loop; frames and "
                                    "signals must flow one way, from sources to the output"))

    # --- output and level ---------------------------------------------------------------------------
    outputs = [n for n in ids if node_by_id[n].type == "output"]
    if not outputs:
        errors.append(Issue(code="no_output", path="nodes",
                            message="the program has no 'output' node; add one and connect the final frame "
                                    "to its 'in' input"))
    elif len(outputs) > 1:
        errors.append(Issue(code="multiple_outputs", node=outputs[1], path=f"nodes[{node_index[outputs[1]]}]",
                            message=f"the program has {len(outputs)} output nodes ({', '.join(outputs)}); "
                                    f"exactly one is allowed"))

    upstream: set[str] = set()
    level: int | None = None
    if len(outputs) == 1:
        reverse: dict[str, set[str]] = defaultdict(set)
        for s, ds in graph.items():
            for d in ds:
                reverse[d].add(s)
        stack = [outputs[0]]
        while stack:
            n = stack.pop()
            if n in upstream:
                continue
            upstream.add(n)
            stack.extend(reverse[n])
        feeding = [(n, BLOCKS[node_by_id[n].type]) for n in ids if n in upstream and node_by_id[n].type in BLOCKS]
        frame = [(n, c.role) for n, c in feeding if c.role not in (Role.signal, Role.output)]
        level = required_level([r for _, r in frame], len(frame))
        limit = min(program.max_level, max_level)
        if level > limit:
            culprit = {3: Role.stage2, 2: Role.mixer}.get(level)
            cause = next((n for n, r in frame if r is culprit), None) if culprit else \
                (frame[1][0] if len(frame) > 1 else None)
            why = {3: "it post-processes in stage 2", 2: "it mixes layers", 1: "it chains blocks"}[level]
            which = (f"the program's max_level ({program.max_level})" if program.max_level < max_level
                     else f"this engine's maximum ({max_level})")
            program_bound = program.max_level < max_level
            errors.append(Issue(code="level_too_high", node=cause,
                                path="max_level" if program_bound or cause is None else f"nodes[{node_index[cause]}]",
                                message=f"the program needs APU level {level} ({why}"
                                        f"{f', node {cause!r}' if cause else ''}), above {which}"))
        for n in ids:
            if n not in upstream:
                warnings.append(Issue(code="unconnected_node", node=n, path=f"nodes[{node_index[n]}]",
                                      message=f"node '{n}' ({node_by_id[n].type}) does not feed the output, "
                                              f"so it has no effect"))

    for node_id, p in params.items():
        if node_by_id[node_id].type == "layer_mixer":
            for k, layer in enumerate(getattr(p, "layers", [])):
                base = f"nodes[{node_index[node_id]}].params.layers[{k}]"
                if layer.weight == 0:
                    warnings.append(Issue(code="zero_weight_layer", node=node_id, port=layer.name,
                                          path=f"{base}.weight",
                                          message=f"layer '{layer.name}' of '{node_id}' has weight 0, so it has "
                                                  f"no effect"))
                if (node_id, layer.name) not in incoming:
                    warnings.append(Issue(code="empty_layer", node=node_id, port=layer.name, path=base,
                                          message=f"layer '{layer.name}' of '{node_id}' has nothing connected"))
    used = {getattr(p, "name", None) for nid, p in params.items() if node_by_id[nid].type == "input"}
    for k, inp in enumerate(program.inputs):
        i = doc_index["inputs"][k]
        if inp.name not in used:
            warnings.append(Issue(code="unused_input", port=inp.name, path=f"inputs[{i}]",
                                  message=f"exposed input '{inp.name}' is not read by any 'input' node"))

    if errors:
        return CompileResult(ValidationReport(valid=False, level=level, errors=errors, warnings=warnings),
                             program=program)

    # --- build ----------------------------------------------------------------------------------------
    order = _topological(ids, graph)
    index = {n: i for i, n in enumerate(order)}
    steps = []
    for n in order:
        wires = [Wire(e.to.port, index[e.from_.node], e.from_.port) for e in good_edges if e.to.node == n]
        steps.append(Step(n, blocks[n], wires))
    out = index[outputs[0]]
    tap = _stage1_tap(steps, out)
    for inp in program.inputs:
        ctx.inputs.setdefault(inp.name, inp.coerce(inp.default))
    apu = APU(steps, out, level or 0, tap, source=program)
    return CompileResult(ValidationReport(valid=True, level=level, warnings=warnings), apu=apu,
                         program=program, params=params)


def _topological(ids: list[str], graph: dict[str, set[str]]) -> list[str]:
    """Kahn's order, ties broken by document order (the graph is known to be acyclic)."""
    pos = {n: k for k, n in enumerate(ids)}
    indeg = {n: 0 for n in ids}
    for s in ids:
        for d in graph.get(s, ()):
            indeg[d] += 1
    order = [n for n in ids if indeg[n] == 0]
    k = 0
    while k < len(order):
        for d in sorted(graph.get(order[k], ()), key=pos.__getitem__):
            indeg[d] -= 1
            if indeg[d] == 0:
                order.append(d)
        k += 1
    return order


def _stage1_tap(steps: list[Step], out: int) -> tuple[int, str] | None:
    """Walk back from the output through stage-2 blocks to the frame entering stage 2."""
    wire = next((w for w in steps[out].wires if w.port == "in"), None)
    crossed = False
    while wire is not None:
        src = steps[wire.src]
        if src.block.role is not Role.stage2:
            return (wire.src, wire.src_port) if crossed else None
        crossed = True
        frame_ins = src.block.ports(src.block.params)[0]
        wire = next((w for w in src.wires if steps[w.src].block.role is not Role.signal and
                     w.port in frame_ins and frame_ins[w.port].type is PortType.frame), None)
    return None


def compile_or_raise(source: Any, embodiment: Embodiment, **kw: Any) -> CompileResult:
    """Compile, raising ProgramError with the full report when the program is invalid."""
    result = compile_program(source, embodiment, **kw)
    if not result.ok:
        raise ProgramError(result.report)
    return result
