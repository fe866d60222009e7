"""Golden programs: valid ones at every APU level, and one broken program per error code.

Each broken program (tests/golden/invalid/<name>.json) has exactly one thing wrong, and
tests/golden/invalid/expected.json says which error it must produce: code, node, port and path
(line/column for malformed JSON). The validator must report exactly that error and nothing else.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from backend.engine.apu import MAX_LEVEL
from backend.graph.builder import ProgramBuilder
from backend.graph.compiler import ERROR_CODES, WARNING_CODES, compile_program
from backend.graph.schema import FORMAT, Program, program_json_schema
from backend.session import EngineSession, SessionError

GOLDEN = Path(__file__).parent / "golden"
VALID = sorted((GOLDEN / "valid").glob("*.json"))
EXPECTED: dict[str, dict] = json.loads((GOLDEN / "invalid" / "expected.json").read_text())


def test_corpus_is_complete():
    assert len(VALID) >= 5
    levels = {int(p.name[len("level")]) for p in VALID}
    assert levels == {0, 1, 2, 3}
    # One broken program named after each error code, and every file has an expectation.
    for code in ERROR_CODES:
        assert (GOLDEN / "invalid" / f"{code}.json").exists(), f"no golden program for error code '{code}'"
        assert EXPECTED[code]["code"] == code
    files = {p.stem for p in (GOLDEN / "invalid").glob("*.json")} - {"expected"}
    assert files == set(EXPECTED)
    assert {e["code"] for e in EXPECTED.values()} <= set(ERROR_CODES)


@pytest.mark.parametrize("path", VALID, ids=lambda p: p.stem)
def test_valid_program_compiles_at_its_level_and_runs(desk, path):
    text = path.read_text()
    result = compile_program(text, desk)
    assert result.report.errors == []
    assert result.report.warnings == []
    assert result.ok and result.report.valid
    level = int(path.name[len("level")])
    assert result.report.level == level == result.apu.level
    # The document survives the model: same program back, editor data included.
    doc = json.loads(text)
    again = Program.model_validate_json(json.dumps(result.program.to_json_dict()))
    assert again == result.program
    assert [n.ui for n in again.nodes] == [n.get("ui", {}) for n in doc["nodes"]]
    assert [n.params for n in again.nodes] == [n.get("params", {}) for n in doc["nodes"]]
    session = EngineSession.create(desk, program_text=text)
    frames = list(session.run_headless(150))
    assert all(np.isfinite(f.position).all() for f in frames)
    assert session.engine.apu.level == level


@pytest.mark.parametrize("name", sorted(EXPECTED), ids=str)
def test_invalid_program_reports_exactly_its_error(desk, name):
    exp = EXPECTED[name]
    text = (GOLDEN / "invalid" / f"{name}.json").read_text()
    result = compile_program(text, desk, max_level=exp.get("engine_max_level", MAX_LEVEL))
    assert not result.ok and result.apu is None and not result.report.valid
    got = [(e.code, e.node, e.port) for e in result.report.errors]
    assert got == [(exp["code"], exp["node"], exp["port"])], [e.render() for e in result.report.errors]
    err = result.report.errors[0]
    if "path" in exp:
        assert err.path == exp["path"]
    if "line" in exp:
        assert (err.line, err.column) == (exp["line"], exp["column"])
        assert f"line {exp['line']}" in err.message
    assert (err.message and err.message[0].islower()) or err.message[0] in "'\"["
    assert err.code in err.render() and err.message in err.render()


def test_all_errors_are_reported_at_once(desk):
    doc = json.loads((GOLDEN / "valid" / "level2_layers.json").read_text())
    doc["nodes"][1]["params"]["amplitude"] = -1  # invalid_param (breath)
    doc["nodes"][3]["params"]["values"]["nose"] = 0.1  # unknown_dof (look)
    doc["nodes"][4]["params"]["layers"][1]["mask"] = ["tail_*", "wing"]  # unknown_dof (mixer), glob is fine
    doc["nodes"].append({"id": "bogus", "type": "teleport", "params": {}})  # unknown_block_type
    doc["edges"].append({"from": {"node": "ghost", "port": "out"}, "to": {"node": "output", "port": "in"}})
    doc["inputs"].append({"name": "breath_depth", "type": "float"})  # duplicate_input
    result = compile_program(json.dumps(doc), desk)
    got = sorted((e.code, e.node, e.port) for e in result.report.errors)
    assert got == sorted(
        [
            ("invalid_param", "breath", "amplitude"),
            ("unknown_dof", "look", "values"),
            ("unknown_dof", "mixer", "layers[1].mask"),
            ("unknown_block_type", "bogus", None),
            ("unknown_node", "ghost", "out"),
            ("duplicate_input", None, "breath_depth"),
        ]
    ), [e.render() for e in result.report.errors]
    # The level is still computed for the parts that are fine.
    assert result.report.level == 2


def test_every_selector_error_has_its_own_path(desk):
    b = ProgramBuilder("dofs")
    s = b.node("sine", "s", dofs=["head_yaw", "nose", "!wing", "stationary:*", "bogus:*", "type:fluffy"])
    b.chain(s, b.output())
    errors = compile_program(b.to_dict(), desk).report.errors
    assert [(e.code, e.port, e.path) for e in errors] == [
        ("unknown_dof", "dofs", "nodes[0].params.dofs[1]"),
        ("unknown_dof", "dofs", "nodes[0].params.dofs[2]"),
        ("unknown_dof", "dofs", "nodes[0].params.dofs[4]"),
        ("unknown_dof", "dofs", "nodes[0].params.dofs[5]"),
    ]
    assert "unknown dimension 'bogus'" in errors[2].message


def test_pose_value_of_the_wrong_kind_is_an_invalid_param(desk):
    b = ProgramBuilder("pose")
    b.chain(b.node("pose", "p", values={"eye_leds": 0.5, "head_yaw": [1, 2, 3]}), b.output())
    errors = compile_program(b.to_dict(), desk).report.errors
    assert [(e.code, e.node, e.port, e.path) for e in errors] == [
        ("invalid_param", "p", "values", "nodes[0].params.values.eye_leds"),
        ("invalid_param", "p", "values", "nodes[0].params.values.head_yaw"),
    ]
    assert "colour" in errors[0].message


def test_union_type_errors_are_one_error_per_value(desk):
    b = ProgramBuilder("pose")
    b.chain(b.node("pose", "p", values={"head_yaw": {"deg": 30}}), b.output())
    errors = compile_program(b.to_dict(), desk).report.errors
    assert [(e.code, e.port, e.path) for e in errors] == [
        ("invalid_param", "values", "nodes[0].params.values.head_yaw")
    ]


def test_edges_around_a_broken_node_do_not_cascade(desk):
    # A node with invalid params keeps its edges: no missing_input downstream, no unknown_node.
    b = ProgramBuilder("cascade")
    s = b.node("sine", "s", amplitude=99)
    g = b.node("gain_offset", "g")
    b.chain(s, g, b.output())
    errors = compile_program(b.to_dict(), desk).report.errors
    assert [(e.code, e.node, e.port) for e in errors] == [("invalid_param", "s", "amplitude")]
    # A node dropped for a schema error (bad ui) is not "unknown" to its edges either.
    doc = b.to_dict()
    doc["nodes"][0]["params"]["amplitude"] = 0.1
    doc["nodes"][0]["ui"] = "left"
    errors = compile_program(doc, desk).report.errors
    assert [(e.code, e.node, e.path) for e in errors] == [("schema", "s", "nodes[0].ui")]


def test_edge_checks_still_apply_on_the_known_end_of_an_unknown_block(desk):
    b = ProgramBuilder("half")
    x = b.node("mystery", "x")
    b.connect(x, b.output(), "out", "input")
    errors = compile_program(b.to_dict(), desk).report.errors
    assert sorted((e.code, e.node, e.port) for e in errors) == [
        ("missing_input", "output", "in"),
        ("unknown_block_type", "x", None),
        ("unknown_port", "output", "input"),
    ]


def test_cycle_reports_the_loop_not_what_it_feeds(desk):
    b = ProgramBuilder("loops")
    a, c = b.node("gain_offset", "a"), b.node("gain_offset", "c")
    d, e = b.node("gain_offset", "d"), b.node("gain_offset", "e")
    mix = b.node("layer_mixer", "mix", layers=[{"name": "one"}, {"name": "two"}])
    b.connect(a, c).connect(c, a).connect(d, e).connect(e, d)
    b.connect(c, mix, "out", "one").connect(e, mix, "out", "two").chain(mix, b.output())
    errors = compile_program(b.to_dict(), desk).report.errors
    assert [(e.code, e.node, e.port) for e in errors] == [("cycle", "a", "in"), ("cycle", "d", "in")]
    assert "a -> c -> a" in errors[0].message
    # A node wired to itself is a loop too.
    b = ProgramBuilder("self")
    g = b.node("gain_offset", "g")
    b.connect(g, g).chain(g, b.output())
    errors = compile_program(b.to_dict(), desk).report.errors
    assert [(e.code, e.node, e.port) for e in errors] == [("cycle", "g", "in")]


def test_top_level_field_errors_do_not_hide_graph_errors(desk):
    doc = json.loads((GOLDEN / "valid" / "level0_rest.json").read_text())
    doc["rate"] = 5000
    doc["nodes"][0]["type"] = "resting"
    errors = compile_program(doc, desk).report.errors
    assert sorted((e.code, e.path) for e in errors) == [
        ("schema", "rate"),
        ("unknown_block_type", "nodes[0].type"),
    ]


@pytest.mark.parametrize(
    "source, code",
    [
        ("", "malformed_json"),
        ("[1, 2", "malformed_json"),
        ("[]", "schema"),
        ("42", "schema"),
        ("null", "schema"),
        ({"nodes": []}, "wrong_format"),
        ({"format": 1}, "wrong_format"),
        ("[" * 100000, "malformed_json"),
        (b'\xef\xbb\xbf{"format": "nutty-program/1", "nodes": 3}', "schema"),
    ],
)
def test_garbage_documents(desk, source, code):
    result = compile_program(source, desk)
    assert result.report.errors and result.report.errors[0].code == code


def test_level_check_names_the_binding_limit(desk):
    text = (GOLDEN / "valid" / "level3_safe_idle.json").read_text()
    for engine_max in (0, 1, 2):
        errors = compile_program(text, desk, max_level=engine_max).report.errors
        assert [(e.code, e.node) for e in errors] == [("level_too_high", "limit")]
        assert f"this engine's maximum ({engine_max})" in errors[0].message
    assert compile_program(text, desk, max_level=3).ok
    # A Level 1 chain over the limit points at the second frame block of the chain.
    text = (GOLDEN / "valid" / "level1_chain.json").read_text()
    errors = compile_program(text, desk, max_level=0).report.errors
    assert [(e.code, e.node) for e in errors] == [("level_too_high", "scale")]
    # An engine that refuses the level: the session rejects the program and keeps running the old one.
    session = EngineSession.create(
        desk, program_text=(GOLDEN / "valid" / "level0_rest.json").read_text(), max_level=1
    )
    apu = session.engine.apu
    with pytest.raises(SessionError) as exc:
        session.load_program((GOLDEN / "valid" / "level3_safe_idle.json").read_text())
    assert exc.value.report.errors[0].code == "level_too_high"
    assert session.engine.apu is apu


@pytest.mark.parametrize(
    "mutate, code",
    [
        (lambda d: d["nodes"].append({"id": "lonely", "type": "sine"}), "unconnected_node"),
        (lambda d: d["nodes"][4]["params"]["layers"][2].update(weight=0.0), "zero_weight_layer"),
        (lambda d: d["edges"].pop(3), "empty_layer"),
        (lambda d: d["inputs"].append({"name": "spare", "type": "bool"}), "unused_input"),
    ],
)
def test_warnings(desk, mutate, code):
    doc = json.loads((GOLDEN / "valid" / "level2_layers.json").read_text())
    mutate(doc)
    report = compile_program(doc, desk).report
    assert report.valid and report.errors == []
    assert code in WARNING_CODES
    assert code in [w.code for w in report.warnings]


def test_invalid_program_changes_nothing_in_a_running_session(desk):
    session = EngineSession.create(desk, program_text=(GOLDEN / "valid" / "level2_layers.json").read_text())
    list(session.run_headless(20))
    apu, program, inputs = session.engine.apu, session.program, session.inputs()
    for name, exp in EXPECTED.items():
        if exp.get("engine_max_level") is not None:
            continue
        with pytest.raises(SessionError) as exc:
            session.load_program((GOLDEN / "invalid" / f"{name}.json").read_text())
        assert exc.value.report.errors[0].code == exp["code"]
        assert session.engine.apu is apu and session.program is program and session.inputs() == inputs
    assert session.engine.swaps == 1
    assert math.isfinite(float(session.engine.tick().position.sum()))


def test_json_schema_export_describes_the_format():
    schema = program_json_schema()
    assert schema["title"] == "Nutty Animation Program"
    props = schema["properties"]
    assert {"format", "name", "robot", "rate", "max_level", "inputs", "nodes", "edges", "ui"} <= set(props)
    assert props["format"]["default"] == FORMAT
    edge = schema["$defs"]["Edge"]["properties"]
    assert set(edge) == {"from", "to"}
    signal = schema["$defs"]["ExposedInput"]["properties"]["type"]
    assert set(signal["enum"]) == {"float", "int", "bool", "string", "vec3", "colour", "event"}


def test_the_format_reference_documents_every_code():
    doc = (Path(__file__).parents[1] / "docs" / "program-format.md").read_text()
    for code in [*ERROR_CODES, *WARNING_CODES]:
        assert f"| `{code}` |" in doc, f"docs/program-format.md does not document '{code}'"


def test_paths_count_items_left_out_for_schema_errors(desk):
    # nodes[0] and edges[0] are malformed and left out; later errors still point at their own index.
    doc = json.loads((GOLDEN / "valid" / "level1_chain.json").read_text())
    doc["nodes"].insert(0, {"id": "junk", "type": "sine", "params": [], "ui": {}})
    doc["edges"].insert(0, {"from": {"node": "sway"}, "to": {"node": "scale", "port": "in"}})
    doc["inputs"].insert(0, {"name": "9lives"})
    doc["nodes"][3]["params"]["gain"] = 11
    doc["edges"].append({"from": {"node": "sway", "port": "out"}, "to": {"node": "output", "port": "in"}})
    doc["inputs"].append({"name": "arousal"})
    errors = compile_program(doc, desk).report.errors
    assert sorted((e.code, e.path) for e in errors) == sorted(
        [
            ("schema", "nodes[0].params"),
            ("schema", "edges[0].from.port"),
            ("schema", "inputs[0].name"),
            ("invalid_param", "nodes[3].params.gain"),
            ("multiple_edges", "edges[5]"),
            ("duplicate_input", "inputs[2].name"),
        ]
    ), [e.render() for e in errors]
