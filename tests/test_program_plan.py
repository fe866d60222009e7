"""Check, then build: `check_program` gives a report and an immutable Plan; `Plan.instantiate` builds
independent APUs from it; block classes add their own rules through check hooks."""

from __future__ import annotations

import ast
import dataclasses
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.blocks.core import Sine
from backend.engine.blocks.mixer import LayerMixer
from backend.graph.builder import ProgramBuilder
from backend.graph.compiler import Plan, check_program, compile_program
from backend.graph.plan import PlannedStep

GOLDEN = Path(__file__).parent / "golden"
LEVEL3 = (GOLDEN / "valid" / "level3_safe_idle.json").read_text()


def test_check_program_gives_the_report_and_a_plan(desk):
    report, plan = check_program(LEVEL3, desk)
    assert report == compile_program(LEVEL3, desk).report and report.valid
    assert isinstance(plan, Plan)
    assert plan.level == 3 and plan.robot == desk.name
    assert [s.node_id for s in plan.steps][plan.output] == "output"
    assert plan.stage1_tap is not None and plan.steps[plan.stage1_tap[0]].node_id == "mixer"
    assert set(plan.params) == {n.id for n in plan.program.nodes}


def test_an_invalid_program_has_no_plan(desk):
    text = (GOLDEN / "invalid" / "cycle.json").read_text()
    report, plan = check_program(text, desk)
    assert plan is None and not report.valid
    assert report == compile_program(text, desk).report


def test_the_plan_is_immutable(desk):
    _, plan = check_program(LEVEL3, desk)
    assert plan is not None
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.level = 1  # type: ignore[misc]  # the point: a frozen plan refuses it
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.steps[0].params = plan.steps[1].params  # type: ignore[misc]  # the point: a frozen plan refuses it
    assert isinstance(plan.steps, tuple) and all(isinstance(s, PlannedStep) for s in plan.steps)
    assert all(isinstance(s.wires, tuple) for s in plan.steps)
    with pytest.raises(TypeError):
        plan.params["breath"] = plan.params["wiggle"]  # type: ignore[index]  # the point: a read-only mapping refuses it


def test_instantiate_twice_gives_independent_apus_with_fresh_state(desk):
    _, plan = check_program(LEVEL3, desk)
    assert plan is not None
    first = plan.instantiate(desk, BlockContext(embodiment=desk, rate=200.0))
    for _ in range(50):
        first.tick(0.005)
    second = plan.instantiate(desk, BlockContext(embodiment=desk, rate=200.0))
    fresh = plan.instantiate(desk, BlockContext(embodiment=desk, rate=200.0))
    # No block, parameter object or step is shared.
    for a, b in zip(first.steps, second.steps):
        assert a.node_id == b.node_id and a.block is not b.block and a.block.params is not b.block.params
        assert a.block.params == b.block.params
    # The second APU starts where any fresh one does, not where the first one is.
    out_second, stage1_second, _ = second.tick(0.005)
    out_fresh, stage1_fresh, _ = fresh.tick(0.005)
    np.testing.assert_array_equal(out_second, out_fresh)
    np.testing.assert_array_equal(stage1_second, stage1_fresh)
    assert not np.array_equal(first.tick(0.005)[1], stage1_second)
    # Ticking one never moves the other.
    for _ in range(10):
        first.tick(0.005)
    np.testing.assert_array_equal(second.tick(0.005)[1], fresh.tick(0.005)[1])
    # A live parameter change on one APU leaves the plan and the other APU alone.
    first.block("breath").update_params(first.block("breath").params.model_copy(update={"amplitude": 0.5}))
    assert plan.params["breath"].amplitude == second.block("breath").params.amplitude == 0.03


def test_instantiate_fills_in_input_defaults_and_refuses_another_robot(desk):
    _, plan = check_program(LEVEL3, desk)
    assert plan is not None
    ctx = BlockContext(embodiment=desk, rate=200.0, inputs={"arousal": 0.9})
    plan.instantiate(desk, ctx)
    assert ctx.inputs == {"arousal": 0.9}  # a value already set is kept
    ctx = BlockContext(embodiment=desk, rate=200.0)
    plan.instantiate(desk, ctx)
    assert ctx.inputs == {"arousal": 0.3}
    with pytest.raises(ValueError, match="other_robot"):
        plan.instantiate(SimpleNamespace(name="other_robot"))  # type: ignore[arg-type]  # a stand-in robot of another name


def _sine_program() -> dict:
    b = ProgramBuilder("hooks")
    b.chain(b.node("sine", "s", dofs=["head_yaw"]), b.output())
    return b.to_dict()


def test_a_block_class_check_hook_is_called_and_reports(desk, monkeypatch):
    calls = []

    def check(cls, params, node):
        calls.append((cls, params.dofs, node.node_id, node.type_name, node.index))
        node.error("invalid_param", "node 's' (sine): the check hook says no", port="dofs", at=("dofs", 0))

    monkeypatch.setattr(Sine, "check", classmethod(check))
    configured = []
    monkeypatch.setattr(Sine, "configure", lambda self: configured.append(self))
    report, plan = check_program(_sine_program(), desk)
    assert calls == [(Sine, ["head_yaw"], "s", "sine", 0)]
    assert plan is None
    assert [(e.code, e.node, e.port, e.path, e.message) for e in report.errors] == [
        ("invalid_param", "s", "dofs", "nodes[0].params.dofs[0]", "node 's' (sine): the check hook says no")
    ]
    assert configured == []  # a node whose own check failed is not configured


def test_a_block_class_check_wiring_hook_sees_the_edges(desk, monkeypatch):
    seen = {}

    def check_wiring(cls, params, node):
        seen[node.node_id] = {p: node.connected(p) for p in ("amplitude", "frequency")}
        node.warning("unconnected_node", "a note from the hook")

    monkeypatch.setattr(Sine, "check_wiring", classmethod(check_wiring))
    doc = _sine_program()
    doc["inputs"] = [{"name": "amp", "default": 0.1, "min": 0.0, "max": 1.0}]
    doc["nodes"].append({"id": "amp", "type": "input", "params": {"name": "amp"}})
    doc["edges"].append({"from": {"node": "amp", "port": "value"}, "to": {"node": "s", "port": "amplitude"}})
    report, plan = check_program(doc, desk)
    assert plan is not None and seen == {"s": {"amplitude": True, "frequency": False}}
    assert [(w.code, w.node, w.path) for w in report.warnings] == [("unconnected_node", "s", "nodes[0]")]


def test_hooks_report_only_documented_codes(desk, monkeypatch):
    monkeypatch.setattr(Sine, "check", classmethod(lambda cls, params, node: node.error("made_up", "nope")))
    with pytest.raises(ValueError, match="made_up"):
        check_program(_sine_program(), desk)


def test_the_mixer_and_input_rules_live_on_their_blocks(desk):
    assert "check_wiring" in vars(LayerMixer) and "check" in vars(BLOCKS["input"])
    doc = json.loads((GOLDEN / "valid" / "level2_layers.json").read_text())
    doc["nodes"][4]["params"]["layers"][1]["weight"] = 0
    doc["edges"] = [e for e in doc["edges"] if e["to"]["port"] != "look"]
    doc["nodes"][2]["params"]["name"] = "breath_dept"
    report = compile_program(doc, desk).report
    assert [(e.code, e.node, e.port, e.path) for e in report.errors] == [
        ("unknown_exposed_input", "in_breath_depth", "name", "nodes[2].params.name")
    ]
    assert "did you mean 'breath_depth'?" in report.errors[0].message
    assert [(w.code, w.node, w.port, w.path) for w in report.warnings] == [
        ("unconnected_node", "look", None, "nodes[3]"),
        ("zero_weight_layer", "mixer", "idle", "nodes[4].params.layers[1].weight"),
        ("empty_layer", "mixer", "look", "nodes[4].params.layers[2]"),
        ("unused_input", None, "breath_depth", "inputs[0]"),
    ]


def _type_name_tests(tree: ast.AST) -> list[str]:
    """Block type names a module compares with or looks up (`x == "layer_mixer"`, `BLOCKS["input"]`)."""
    names = set(BLOCKS)
    found = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Compare):
            parts = [n.left, *n.comparators]
            consts = [
                c for p in parts for c in ([p] if isinstance(p, ast.Constant) else getattr(p, "elts", []))
            ]
            found += [c.value for c in consts if isinstance(c, ast.Constant) and c.value in names]
        elif isinstance(n, ast.Subscript) and isinstance(n.slice, ast.Constant) and n.slice.value in names:
            found.append(n.slice.value)
    return found


def test_the_checker_names_no_block_type():
    graph = Path(__file__).parent.parent / "backend" / "graph"
    for path in [graph / "compiler.py", graph / "plan.py", *sorted((graph / "checks").glob("*.py"))]:
        assert _type_name_tests(ast.parse(path.read_text())) == [], path.name
    assert _type_name_tests(
        ast.parse('if node.type == "layer_mixer" or kind in ("input", "x"): BLOCKS["sine"]')
    ) == ["layer_mixer", "input", "sine"]


def test_compile_builds_each_block_once_and_a_second_apu_afresh(desk, monkeypatch):
    """The checks' trial-built blocks become the first APU's blocks in the same context (they are fresh:
    configured, reset, never ticked); any other APU of the plan builds its own."""
    built: list[str] = []
    original = Sine.__init__

    def counting(self, params, ctx, node_id=""):
        built.append(node_id)
        original(self, params, ctx, node_id)

    monkeypatch.setattr(Sine, "__init__", counting)
    ctx = BlockContext(embodiment=desk, rate=100.0)
    result = compile_program(LEVEL3, desk, ctx=ctx)
    sines = [s.node_id for s in result.apu.steps if isinstance(s.block, Sine)]
    assert sines and sorted(built) == sorted(sines)  # once each, during the checks
    _, plan = check_program(LEVEL3, desk, ctx=ctx)
    built.clear()
    first = plan.instantiate(desk, ctx)  # takes the probes over
    assert built == []
    second = plan.instantiate(desk, ctx)  # builds its own
    assert sorted(built) == sorted(sines)
    for a, b in zip(first.steps, second.steps):
        assert a.block is not b.block and a.block.params is not plan.params[a.node_id]
    other = plan.instantiate(desk, BlockContext(embodiment=desk, rate=100.0))  # another context: fresh blocks
    assert all(a.block is not b.block for a, b in zip(first.steps, other.steps))
    np.testing.assert_array_equal(first.tick(0.01)[0], other.tick(0.01)[0])
