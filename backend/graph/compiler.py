"""Validate an Animation Program against a robot and compile it into an APU, in one pass.

`compile_program` returns *every* error at once (ComfyUI-style), each with a machine-readable code,
the node id, the port or parameter path and a sentence for a person; plus warnings. A program with
errors produces no APU, so loading is atomic: nothing in a running engine changes.

Error codes
  malformed_json, wrong_format, schema, duplicate_node, unknown_block_type, unknown_param,
  invalid_param, unknown_dof, block_config, unknown_node, unknown_port, port_type_mismatch,
  multiple_edges, missing_input, cycle, no_output, multiple_outputs, level_too_high,
  unknown_exposed_input, duplicate_input, invalid_input
Warning codes
  unconnected_node, zero_weight_layer, empty_layer, unused_input
"""

from __future__ import annotations

import difflib
import json
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, Field, ValidationError

from backend.engine.apu import APU, MAX_LEVEL, Step, Wire, required_level
from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block, BlockContext, BlockParams, Port, PortType, Role, port_accepts
from backend.engine.embodiment import Embodiment
from backend.engine.selectors import SelectorError
from backend.graph.schema import FORMAT, Edge, ExposedInput, Node, Program


class Issue(BaseModel):
    """One validation error or warning."""

    code: str
    node: str | None = None
    port: str | None = None
    message: str
    path: str | None = Field(None, description="JSON path in the document, e.g. nodes[2].params.amplitude")
    line: int | None = None
    column: int | None = None


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


# --------------------------------------------------------------------------------------------------


def _loc(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _parse_document(source: Any, errors: list[Issue]) -> dict[str, Any] | None:
    if isinstance(source, Program):
        return source.to_json_dict()
    if isinstance(source, (bytes, bytearray)):
        source = source.decode("utf-8", errors="replace")
    if isinstance(source, str):
        try:
            source = json.loads(source)
        except json.JSONDecodeError as exc:
            errors.append(Issue(code="malformed_json", line=exc.lineno, column=exc.colno,
                                message=f"malformed JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"))
            return None
    if not isinstance(source, dict):
        errors.append(Issue(code="schema", message=f"a program is a JSON object, got {type(source).__name__}"))
        return None
    return source


def _parse_program(doc: dict[str, Any], errors: list[Issue]) -> Program | None:
    """Parse leniently: a broken node, edge or input is reported and left out, the rest goes on."""
    fmt = doc.get("format")
    if fmt != FORMAT:
        errors.append(Issue(code="wrong_format", path="format",
                            message=f"format is {fmt!r}; this engine reads '{FORMAT}'"))
        return None
    parts: dict[str, list[Any]] = {"nodes": [], "edges": [], "inputs": []}
    models = {"nodes": Node, "edges": Edge, "inputs": ExposedInput}
    for key, model in models.items():
        raw = doc.get(key, [])
        if not isinstance(raw, list):
            errors.append(Issue(code="schema", path=key, message=f"'{key}' must be a list"))
            continue
        for i, item in enumerate(raw):
            try:
                parts[key].append(model.model_validate(item))
            except ValidationError as exc:
                node_id = item.get("id") if key == "nodes" and isinstance(item, dict) else None
                for err in exc.errors():
                    path = _loc((key, i, *err["loc"]))
                    errors.append(Issue(code="schema", node=node_id if isinstance(node_id, str) else None,
                                        path=path, message=f"{path}: {err['msg']}"))
    rest = {k: v for k, v in doc.items() if k not in models}
    try:
        return Program.model_validate({**rest, **{k: [] for k in models}}).model_copy(update=parts)
    except ValidationError as exc:
        for err in exc.errors():
            path = _loc(tuple(err["loc"]))
            errors.append(Issue(code="schema", path=path, message=f"{path}: {err['msg']}"))
        return None


def _params_errors(node: Node, index: int, cls: type[Block], exc: ValidationError) -> list[Issue]:
    out = []
    for err in exc.errors():
        loc = tuple(err["loc"])
        name = str(loc[0]) if loc else None
        path = _loc((f"nodes[{index}].params", *loc))
        if err["type"] == "extra_forbidden":
            known = list(cls.Params.model_fields)
            hint = difflib.get_close_matches(name or "", known, n=1)
            extra = f"; did you mean '{hint[0]}'?" if hint else f"; known: {known}"
            out.append(Issue(code="unknown_param", node=node.id, port=name, path=path,
                             message=f"node '{node.id}' ({node.type}) has no parameter '{name}'{extra}"))
        else:
            got = err.get("input")
            out.append(Issue(code="invalid_param", node=node.id, port=name, path=path,
                             message=f"node '{node.id}' ({node.type}) parameter '{_loc(loc)}': {err['msg']} (got {got!r})"))
    return out


def compile_program(source: Any, embodiment: Embodiment, *, max_level: int = MAX_LEVEL,
                    ctx: BlockContext | None = None, rate: float = 100.0) -> CompileResult:
    """Validate `source` (JSON text, dict or Program) for `embodiment` and build its APU if valid."""
    errors: list[Issue] = []
    warnings: list[Issue] = []
    doc = _parse_document(source, errors)
    program = _parse_program(doc, errors) if doc is not None else None
    if program is None:
        return CompileResult(ValidationReport(valid=False, errors=errors))
    ctx = ctx or BlockContext(embodiment=embodiment, rate=rate)

    # --- exposed inputs ---------------------------------------------------------------------------
    declared: dict[str, ExposedInput] = {}
    for i, inp in enumerate(program.inputs):
        if inp.name in declared:
            errors.append(Issue(code="duplicate_input", path=f"inputs[{i}]", port=inp.name,
                                message=f"exposed input '{inp.name}' is declared twice"))
            continue
        try:
            inp.coerce(inp.default)
        except ValueError as exc:
            errors.append(Issue(code="invalid_input", path=f"inputs[{i}].default", port=inp.name, message=str(exc)))
        declared[inp.name] = inp

    # --- nodes --------------------------------------------------------------------------------------
    blocks: dict[str, Block] = {}
    params: dict[str, BlockParams] = {}
    ports: dict[str, tuple[dict[str, Port], dict[str, Port]]] = {}
    node_by_id: dict[str, Node] = {}
    for i, node in enumerate(program.nodes):
        if node.id in node_by_id:
            errors.append(Issue(code="duplicate_node", node=node.id, path=f"nodes[{i}].id",
                                message=f"node id '{node.id}' is used twice"))
            continue
        node_by_id[node.id] = node
        cls = BLOCKS.get(node.type)
        if cls is None:
            hint = difflib.get_close_matches(node.type, list(BLOCKS), n=1)
            extra = f"; did you mean '{hint[0]}'?" if hint else ""
            errors.append(Issue(code="unknown_block_type", node=node.id, path=f"nodes[{i}].type",
                                message=f"node '{node.id}': unknown block type '{node.type}'{extra}"))
            continue
        try:
            p = cls.Params.model_validate(node.params)
        except ValidationError as exc:
            errors.extend(_params_errors(node, i, cls, exc))
            continue
        params[node.id] = p
        ports[node.id] = cls.ports(p)
        if cls.type_name == "input":
            decl = declared.get(p.name)  # type: ignore[attr-defined]
            if decl is None:
                errors.append(Issue(code="unknown_exposed_input", node=node.id, port="name",
                                    path=f"nodes[{i}].params.name",
                                    message=f"node '{node.id}' reads exposed input '{p.name}', which the program "
                                            f"does not declare (declared: {sorted(declared)})"))  # type: ignore[attr-defined]
            elif decl.type != p.type:  # type: ignore[attr-defined]
                errors.append(Issue(code="port_type_mismatch", node=node.id, port="value",
                                    path=f"nodes[{i}].params.type",
                                    message=f"node '{node.id}' reads '{decl.name}' as {p.type} but it is declared "
                                            f"{decl.type}"))  # type: ignore[attr-defined]
        try:
            blocks[node.id] = cls(p, ctx, node.id)
        except SelectorError as exc:
            errors.append(Issue(code="unknown_dof", node=node.id, port=None, path=f"nodes[{i}].params",
                                message=f"node '{node.id}' ({node.type}): {exc}"))
        except (ValueError, KeyError) as exc:
            errors.append(Issue(code="block_config", node=node.id, path=f"nodes[{i}].params",
                                message=f"node '{node.id}' ({node.type}): {exc}"))

    # --- edges --------------------------------------------------------------------------------------
    incoming: dict[tuple[str, str], Edge] = {}
    graph: dict[str, set[str]] = defaultdict(set)  # node -> downstream nodes
    good_edges: list[Edge] = []
    for i, edge in enumerate(program.edges):
        src, dst = edge.from_, edge.to
        ok = True
        for end, role in ((src, "from"), (dst, "to")):
            if end.node not in node_by_id:
                errors.append(Issue(code="unknown_node", node=end.node, port=end.port, path=f"edges[{i}].{role}.node",
                                    message=f"edge {i} {role} unknown node '{end.node}'"))
                ok = False
        if not ok:
            continue
        if src.node not in ports or dst.node not in ports:
            continue  # the node itself is already reported
        out_ports, in_ports = ports[src.node][1], ports[dst.node][0]
        if src.port not in out_ports:
            errors.append(Issue(code="unknown_port", node=src.node, port=src.port, path=f"edges[{i}].from.port",
                                message=f"node '{src.node}' ({node_by_id[src.node].type}) has no output '{src.port}' "
                                        f"(outputs: {sorted(out_ports)})"))
            ok = False
        if dst.port not in in_ports:
            errors.append(Issue(code="unknown_port", node=dst.node, port=dst.port, path=f"edges[{i}].to.port",
                                message=f"node '{dst.node}' ({node_by_id[dst.node].type}) has no input '{dst.port}' "
                                        f"(inputs: {sorted(in_ports)})"))
            ok = False
        if not ok:
            continue
        t_out, t_in = out_ports[src.port].type, in_ports[dst.port].type
        if not port_accepts(t_in, t_out):
            errors.append(Issue(code="port_type_mismatch", node=dst.node, port=dst.port, path=f"edges[{i}]",
                                message=f"cannot connect {t_out.value} output '{src.node}.{src.port}' to "
                                        f"{t_in.value} input '{dst.node}.{dst.port}'"))
            continue
        key = (dst.node, dst.port)
        if key in incoming:
            errors.append(Issue(code="multiple_edges", node=dst.node, port=dst.port, path=f"edges[{i}]",
                                message=f"input '{dst.node}.{dst.port}' already has an edge (from "
                                        f"'{incoming[key].from_.node}.{incoming[key].from_.port}'); one edge per input"))
            continue
        incoming[key] = edge
        graph[src.node].add(dst.node)
        good_edges.append(edge)

    for node_id, (ins, _) in ports.items():
        for pname, port in ins.items():
            if port.required and (node_id, pname) not in incoming:
                errors.append(Issue(code="missing_input", node=node_id, port=pname,
                                    message=f"node '{node_id}' ({node_by_id[node_id].type}) needs an edge into "
                                            f"its '{pname}' input"))

    # --- cycles (Kahn) --------------------------------------------------------------------------------
    ids = [n.id for n in program.nodes if n.id in ports]
    indeg = {n: 0 for n in ids}
    for s in ids:
        for d in graph[s]:
            if d in indeg:
                indeg[d] += 1
    order = [n for n in ids if indeg[n] == 0]
    k = 0
    while k < len(order):
        for d in sorted(graph[order[k]], key=ids.index):
            if d in indeg:
                indeg[d] -= 1
                if indeg[d] == 0:
                    order.append(d)
        k += 1
    cyclic = [n for n in ids if indeg[n] > 0]
    if cyclic:
        errors.append(Issue(code="cycle", node=cyclic[0],
                            message=f"the graph has a cycle through nodes {cyclic}; frames must flow one way"))

    # --- output and level -------------------------------------------------------------------------------
    outputs = [n.id for n in program.nodes if n.type == "output"]
    if not outputs:
        errors.append(Issue(code="no_output", message="the program has no 'output' node"))
    elif len(outputs) > 1:
        errors.append(Issue(code="multiple_outputs", node=outputs[1],
                            message=f"the program has {len(outputs)} output nodes {outputs}; exactly one is allowed"))

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
        feeding = [BLOCKS[node_by_id[n].type] for n in upstream if node_by_id[n].type in BLOCKS]
        frame_roles = [c.role for c in feeding if c.role not in (Role.signal, Role.output)]
        level = required_level(frame_roles, len(frame_roles))
        limit = min(program.max_level, max_level)
        if level > limit:
            which = "the program's max_level" if program.max_level < max_level else "this engine's maximum"
            errors.append(Issue(code="level_too_high",
                                message=f"the program needs APU level {level}, above {which} ({limit})"))
        for n in program.nodes:
            if n.id not in upstream and n.id in node_by_id and node_by_id[n.id] is n:
                warnings.append(Issue(code="unconnected_node", node=n.id,
                                      message=f"node '{n.id}' ({n.type}) does not feed the output"))

    for node_id, p in params.items():
        if node_by_id[node_id].type == "layer_mixer":
            for layer in p.layers:  # type: ignore[attr-defined]
                if layer.weight == 0:
                    warnings.append(Issue(code="zero_weight_layer", node=node_id, port=layer.name,
                                          message=f"layer '{layer.name}' of '{node_id}' has weight 0 and has no effect"))
                if (node_id, layer.name) not in incoming:
                    warnings.append(Issue(code="empty_layer", node=node_id, port=layer.name,
                                          message=f"layer '{layer.name}' of '{node_id}' has nothing connected"))
    used = {p.name for nid, p in params.items() if node_by_id[nid].type == "input"}  # type: ignore[attr-defined]
    for inp in program.inputs:
        if inp.name not in used:
            warnings.append(Issue(code="unused_input", port=inp.name,
                                  message=f"exposed input '{inp.name}' is not read by any node"))

    if errors:
        return CompileResult(ValidationReport(valid=False, level=level, errors=errors, warnings=warnings),
                             program=program)

    # --- build ----------------------------------------------------------------------------------------------
    index = {n: i for i, n in enumerate(order)}
    steps = []
    for n in order:
        wires = [Wire(e.to.port, index[e.from_.node], e.from_.port) for e in good_edges if e.to.node == n]
        steps.append(Step(n, blocks[n], wires))
    out = index[outputs[0]]
    tap = _stage1_tap(steps, out, index)
    for inp in program.inputs:
        ctx.inputs.setdefault(inp.name, inp.coerce(inp.default))
    apu = APU(steps, out, level or 0, tap, source=program)
    return CompileResult(ValidationReport(valid=True, level=level, warnings=warnings), apu=apu,
                         program=program, params=params)


def _stage1_tap(steps: list[Step], out: int, index: dict[str, int]) -> tuple[int, str] | None:
    """Walk back from the output through stage-2 blocks to the frame entering stage 2."""
    wire = next((w for w in steps[out].wires if w.port == "in"), None)
    crossed = False
    while wire is not None:
        src = steps[wire.src]
        if src.block.role is not Role.stage2:
            return (wire.src, wire.src_port) if crossed else None
        crossed = True
        wire = next((w for w in src.wires if steps[w.src].block.role is not Role.signal and
                     isinstance(src.block.ports(src.block.params)[0].get(w.port), Port) and
                     src.block.ports(src.block.params)[0][w.port].type is PortType.frame), None)
    return None


def compile_or_raise(source: Any, embodiment: Embodiment, **kw: Any) -> CompileResult:
    """Compile, raising ProgramError with the full report when the program is invalid."""
    result = compile_program(source, embodiment, **kw)
    if not result.ok:
        raise ProgramError(result.report)
    return result
