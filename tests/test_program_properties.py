"""Property tests of the program format: random valid graphs round-trip and compile; random
mutations of them (and random garbage) never crash the validator."""

from __future__ import annotations

import copy
import enum
import json
import typing

import annotated_types as at
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.blocks.base import Role
from backend.engine.blocks.mixer import LayerSpec
from backend.engine.embodiment import load_embodiment
from backend.graph.compiler import ERROR_CODES, WARNING_CODES, compile_program
from backend.graph.roundtrip import apu_to_program
from backend.graph.schema import FORMAT, Program

EMB = load_embodiment("nutty_desk")
CONTINUOUS = EMB.continuous_names
SELECTORS = [d.name for d in EMB.dofs] + [
    "*",
    "head_*",
    "ear_?",
    "*_pitch",
    "stationary:*",
    "display:*",
    "stationary:neck_*",
    "type:continuous",
    "!ear_left",
    "tail_*",
]
SETTINGS = settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# --- random parameters from the blocks' own schemas ----------------------------------------------------


def _number(info, integer: bool = False):
    lo = hi = None
    excl_lo = False
    for m in info.metadata:
        if isinstance(m, at.Ge):
            lo = m.ge
        elif isinstance(m, at.Gt):
            lo, excl_lo = m.gt, True
        elif isinstance(m, at.Le):
            hi = m.le
    lo = -100.0 if lo is None else lo
    hi = 100.0 if hi is None else hi
    if integer:
        return st.integers(int(lo), int(hi))
    if excl_lo:
        lo += 1e-3  # strictly above the bound, even after rounding
    return st.floats(lo, hi, allow_nan=False).map(lambda x: min(max(round(x, 6), lo), hi))


def _field(name: str, info):
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    widget = extra.get("x-widget")
    ann = info.annotation
    if widget == "dofs":
        return st.lists(st.sampled_from(SELECTORS), min_size=1, max_size=4)
    if widget == "pose":
        return st.dictionaries(
            st.sampled_from(CONTINUOUS), st.floats(-3, 3).map(lambda x: round(x, 4)), max_size=4
        )
    if widget in ("posture", "clip", "layers"):
        return None  # robot resources and structure: handled by the graph strategy
    if ann is float:
        return _number(info)
    if ann is int:
        return _number(info, integer=True)
    if ann is bool:
        return st.booleans()
    if typing.get_origin(ann) is typing.Literal:
        return st.sampled_from(typing.get_args(ann))
    if isinstance(ann, type) and issubclass(ann, enum.Enum):
        return st.sampled_from([m.value for m in ann])
    return None


@st.composite
def params_for(draw, model, block=None):
    out = {}
    for name, info in model.model_fields.items():
        strat = _field(name, info)
        if strat is not None and draw(st.booleans()):
            out[name] = draw(strat)
    try:  # fields drawn one by one may break a cross-field rule (min <= mean <= max) or not fit the
        # robot (a yaw DoF as a pitch DoF): such drawings are invalid programs, so use the defaults
        params = model.model_validate(out)
        if block is not None:
            block(params, BlockContext(embodiment=EMB, rate=100.0), "probe")
    except ValueError:
        return {}
    return out


ui = st.fixed_dictionaries(
    {
        "x": st.floats(-2000, 2000).map(lambda v: round(v, 1)),
        "y": st.floats(-2000, 2000).map(lambda v: round(v, 1)),
    },
    optional={
        "colour": st.sampled_from(["#ff0000", "#7fb3d5"]),
        "collapsed": st.booleans(),
        "label": st.text(max_size=12),
    },
)


# --- random valid graphs ---------------------------------------------------------------------------


def _usable(kind: str) -> bool:
    """Blocks whose parameters this file can draw (no required ones) and whose only required input is
    the frame `in`: new blocks join the random graphs as they are registered."""
    cls = BLOCKS[kind]
    if any(f.is_required() for f in cls.Params.model_fields.values()):
        return False
    try:
        ins = cls.ports(cls.Params())[0]
    except Exception:
        return False
    return all(not p.required or name == "in" for name, p in ins.items())


SOURCES = sorted(
    k
    for k, c in BLOCKS.items()
    if c.role is Role.source and _usable(k) and not any(p.required for p in c.ports(c.Params())[0].values())
)
OPERATORS = sorted(k for k, c in BLOCKS.items() if c.role is Role.operator and _usable(k))
STAGE2 = sorted(k for k, c in BLOCKS.items() if c.role is Role.stage2 and _usable(k))


@st.composite
def valid_programs(draw):
    """A random valid program and the APU level its shape needs.

    Shapes: source -> operators* -> [mixer of such chains] -> [safety limiter] -> output, with
    optional exposed inputs driving float ports of sources/operators, and stray nodes."""
    nodes: list[dict] = []
    edges: list[dict] = []
    inputs: list[dict] = []
    counter = iter(range(10_000))

    def add(kind: str, params: dict | None = None) -> str:
        nid = f"{kind}_{next(counter)}"
        p = draw(params_for(BLOCKS[kind].Params, BLOCKS[kind])) if params is None else params
        nodes.append({"id": nid, "type": kind, "params": p, "ui": draw(ui)})
        return nid

    def link(a: str, b: str, port: str = "in", src_port: str = "out") -> None:
        edges.append({"from": {"node": a, "port": src_port}, "to": {"node": b, "port": port}})

    def chain() -> tuple[str, int]:
        head = add(draw(st.sampled_from(SOURCES)))
        n = 1
        for _ in range(draw(st.integers(0, 3))):
            op = add(draw(st.sampled_from(OPERATORS)))
            link(head, op)
            head, n = op, n + 1
        return head, n

    def maybe_drive(node_id: str) -> None:
        kind = next(n["type"] for n in nodes if n["id"] == node_id)
        ports = [
            p
            for p, port in BLOCKS[kind]
            .ports(
                BLOCKS[kind].Params.model_validate(next(n["params"] for n in nodes if n["id"] == node_id))
            )[0]
            .items()
            if port.type.value == "float"
        ]
        if ports and draw(st.booleans()):
            port = draw(st.sampled_from(ports))
            name = f"knob_{len(inputs)}"
            lo = draw(st.floats(-1, 0).map(lambda v: round(v, 3)))
            inputs.append({"name": name, "type": "float", "default": 0.0, "min": lo, "max": lo + 2.0})
            link(add("input", {"name": name, "type": "float"}), node_id, port, "value")

    if draw(st.booleans()):
        n_layers = draw(st.integers(1, 4))
        names = [f"layer{k}" for k in range(n_layers)]
        layers = []
        for nm in names:
            spec = draw(params_for(LayerSpec))
            spec.pop("name", None)
            layers.append({"name": nm, **spec})
        mix = add("layer_mixer", {"layers": layers})
        for nm in names:
            head, _ = chain()
            maybe_drive(head)
            link(head, mix, nm)
        head, level = mix, 2
    else:
        head, n = chain()
        maybe_drive(head)
        level = 0 if n == 1 else 1
    if draw(st.booleans()):
        lim = add(draw(st.sampled_from(STAGE2)))
        link(head, lim)
        head, level = lim, 3
    link(head, add("output", {}))
    order = draw(st.permutations(range(len(nodes))))
    doc = {
        "format": FORMAT,
        "name": draw(st.text(min_size=1, max_size=20)),
        "description": draw(st.text(max_size=30)),
        "max_level": 3,
        "inputs": inputs,
        "nodes": [nodes[k] for k in order],
        "edges": draw(st.permutations(edges)),
        "ui": draw(st.dictionaries(st.sampled_from(["zoom", "x", "y"]), st.floats(-10, 10))),
    }
    if draw(st.booleans()):
        doc["rate"] = draw(st.sampled_from([50, 100, 200]))
    return doc, level


def test_the_random_graphs_cover_the_core_blocks():
    assert {"sine", "rest_pose", "pose"} <= set(SOURCES)
    assert {"gain_offset", "mask"} <= set(OPERATORS) and "safety_limiter" in STAGE2


@SETTINGS
@given(valid_programs())
def test_random_valid_programs_round_trip_and_compile(case):
    doc, level = case
    program = Program.model_validate(doc)
    text = program.model_dump_json(by_alias=True, exclude_none=True)
    again = Program.model_validate_json(text)
    assert again == program
    assert [n.ui for n in again.nodes] == [n["ui"] for n in doc["nodes"]]
    result = compile_program(text, EMB)
    assert result.report.errors == [], [e.render() for e in result.report.errors]
    assert result.ok and result.report.level == level
    event(f"level {level}")
    assert {w.code for w in result.report.warnings} <= {"unconnected_node", "zero_weight_layer"}
    # Compiled program -> graph is lossless, and it runs.
    assert apu_to_program(result.apu) == program
    for _ in range(3):
        final, _stage1, _ = result.apu.tick(0.01)
        assert final.shape == (EMB.n_channels,)


# --- random mutations never crash the validator --------------------------------------------------------

json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**6), 10**6)
    | st.floats(allow_nan=True)
    | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=8,
)


def _paths(data, prefix=()):
    yield prefix
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _paths(v, (*prefix, i))


def _get(data, path):
    for p in path:
        data = data[p]
    return data


@st.composite
def mutated(draw):
    doc, _ = draw(valid_programs())
    doc = copy.deepcopy(doc)
    ids = [n["id"] for n in doc["nodes"]]
    kind = draw(
        st.sampled_from(
            [
                "drop_node",
                "rename_node",
                "rewire",
                "corrupt_param",
                "change_type",
                "delete_field",
                "replace_subtree",
                "add_edge",
                "text_garbage",
                "truncate",
            ]
        )
    )
    if kind == "drop_node":
        doc["nodes"].pop(draw(st.integers(0, len(doc["nodes"]) - 1)))
    elif kind == "rename_node":
        node = draw(st.sampled_from(doc["nodes"]))
        node["id"] = draw(st.sampled_from(ids) | st.text(max_size=8))
    elif kind == "rewire" and doc["edges"]:
        edge = draw(st.sampled_from(doc["edges"]))
        end = edge[draw(st.sampled_from(["from", "to"]))]
        end["node"] = draw(st.sampled_from(ids) | st.text(max_size=5))
        end["port"] = draw(
            st.sampled_from(["in", "out", "value", "amplitude", "gain", "layer0", "base"])
            | st.text(max_size=5)
        )
    elif kind == "corrupt_param":
        node = draw(st.sampled_from(doc["nodes"]))
        keys = [*list(node["params"]), "dofs", "amplitude", "layers", "values", "name", "bogus"]
        node["params"][draw(st.sampled_from(keys))] = draw(json_values)
    elif kind == "change_type":
        node = draw(st.sampled_from(doc["nodes"]))
        node["type"] = draw(st.sampled_from(sorted(BLOCKS)) | st.text(max_size=8) | json_values)
    elif kind == "delete_field":
        paths = [p for p in _paths(doc) if p]
        path = draw(st.sampled_from(paths))
        parent = _get(doc, path[:-1])
        del parent[path[-1]]
    elif kind == "replace_subtree":
        paths = [p for p in _paths(doc) if p]
        path = draw(st.sampled_from(paths))
        _get(doc, path[:-1])[path[-1]] = draw(json_values)
    elif kind == "add_edge":
        a, b = draw(st.sampled_from(ids)), draw(st.sampled_from(ids))
        doc["edges"].append(
            {
                "from": {"node": a, "port": "out"},
                "to": {"node": b, "port": draw(st.sampled_from(["in", "layer0", "gain"]))},
            }
        )
    elif kind == "text_garbage":
        return draw(st.text(max_size=40) | st.binary(max_size=40))
    elif kind == "truncate":
        text = json.dumps(doc)
        return text[: draw(st.integers(0, len(text)))]
    return doc


def _check_report(result):
    report = result.report
    json.loads(report.model_dump_json())  # serialisable for --json and the API
    assert {e.code for e in report.errors} <= set(ERROR_CODES)
    assert {w.code for w in report.warnings} <= set(WARNING_CODES)
    assert all(e.message for e in report.errors + report.warnings)
    if result.ok:
        assert report.valid and report.errors == [] and result.apu is not None
    else:
        assert not report.valid and report.errors and result.apu is None


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_random_mutations_never_crash_the_validator(source):
    result = compile_program(source, EMB)
    _check_report(result)
    event("valid" if result.ok else f"first error: {result.report.errors[0].code}")
    if isinstance(source, dict) and result.ok:
        # Whatever survived the mutation is a real program: it round-trips and runs.
        assert apu_to_program(result.apu) == Program.model_validate(source)
        result.apu.tick(0.01)


@settings(max_examples=60, deadline=None)
@given(json_values)
def test_any_json_value_is_an_error_not_a_crash(value):
    for source in (value, json.dumps(value, allow_nan=True)):
        result = compile_program(source, EMB)
        _check_report(result)
        assert not result.ok


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -1e308, 1e308])
def test_non_finite_params_are_rejected(bad):
    doc = {
        "format": FORMAT,
        "nodes": [{"id": "s", "type": "sine", "params": {"amplitude": bad}}, {"id": "o", "type": "output"}],
        "edges": [{"from": {"node": "s", "port": "out"}, "to": {"node": "o", "port": "in"}}],
    }
    errors = compile_program(doc, EMB).report.errors
    assert [(e.code, e.node, e.port) for e in errors] == [("invalid_param", "s", "amplitude")]
