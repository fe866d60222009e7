"""Subgraphs: the format, their checks (errors naming the subgraph, the inner node and port), the
flattening (ids `<instance>/<inner>`, rewired edges), frames identical to the same blocks written flat,
live parameter changes of inner blocks, cook times, round trips and the library kind `subgraphs`."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.graph.compiler import compile_program
from backend.graph.roundtrip import apu_to_program
from backend.graph.schema import Program
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parent.parent / "robots" / "nutty_desk" / "programs"
IDLE = ["breathe", "wander", "wander_filter", "weight_shift", "blink", "eyelid_filter"]


def interactive() -> dict:
    return json.loads((PROGRAMS / "interactive.json").read_text())


def grouped(name: str = "idle", definition: str = "idle") -> dict:
    """The interactive program with its idle layer grouped into one subgraph node `name`: every wire
    crossing the group's edge becomes an exposed port."""
    d = interactive()
    pos = min(i for i, n in enumerate(d["nodes"]) if n["id"] in IDLE)
    inner = [n for n in d["nodes"] if n["id"] in IDLE]
    ins, outs, inner_edges, edges = [], [], [], []
    for e in d["edges"]:
        a, b = e["from"]["node"] in IDLE, e["to"]["node"] in IDLE
        if a and b:
            inner_edges.append(e)
        elif b:
            port = f"{e['to']['node']}_{e['to']['port']}"
            ins.append({"name": port, "node": e["to"]["node"], "port": e["to"]["port"]})
            edges.append({"from": e["from"], "to": {"node": name, "port": port}})
        elif a:
            port = f"{e['from']['node']}_{e['from']['port']}"
            if all(o["name"] != port for o in outs):
                outs.append({"name": port, "node": e["from"]["node"], "port": e["from"]["port"]})
            edges.append({"from": {"node": name, "port": port}, "to": e["to"]})
        else:
            edges.append(e)
    nodes = [n for n in d["nodes"] if n["id"] not in IDLE]
    nodes.insert(
        pos, {"id": name, "type": "subgraph", "params": {"subgraph": definition}, "ui": {"x": 620, "y": 600}}
    )
    d.update(
        nodes=nodes,
        edges=edges,
        subgraphs={
            definition: {
                "description": "the idle layer",
                "nodes": inner,
                "edges": inner_edges,
                "inputs": ins,
                "outputs": outs,
            }
        },
    )
    return d


def flat_named(name: str = "idle") -> dict:
    """The same blocks written flat, under the ids the flattening gives them (`idle/breathe`)."""
    d = interactive()
    ren = {i: f"{name}/{i}" for i in IDLE}
    pos = min(i for i, n in enumerate(d["nodes"]) if n["id"] in IDLE)
    inner = [dict(n, id=ren[n["id"]]) for n in d["nodes"] if n["id"] in IDLE]
    nodes = [n for n in d["nodes"] if n["id"] not in IDLE]
    nodes[pos:pos] = inner
    d["nodes"] = nodes
    for e in d["edges"]:
        for end in (e["from"], e["to"]):
            end["node"] = ren.get(end["node"], end["node"])
    return d


def errors(desk, doc) -> list:
    report = compile_program(doc, desk).report
    assert not report.valid
    return report.errors


# --- format and checks -----------------------------------------------------------------------------


def test_grouped_program_is_valid_and_keeps_its_document(desk):
    doc = grouped()
    Program.model_validate(doc)
    result = compile_program(doc, desk)
    assert result.ok, [e.render() for e in result.report.errors]
    assert (
        result.program.subgraphs is not None and "idle" in result.program.subgraphs
    )  # the document as written
    assert result.program.node("idle").type == "subgraph"
    ids = [s.node_id for s in result.apu.steps]
    assert {f"idle/{i}" for i in IDLE} <= set(ids) and "idle" not in ids and "breathe" not in ids
    assert set(result.params) == set(ids)


def test_flattening_rewires_edges_through_exposed_ports(desk):
    result = compile_program(grouped(), desk)
    flat = result.flat
    keys = {e.key() for e in flat.edges}
    assert ("breath_amplitude", "value", "idle/breathe", "amplitude") in keys  # into the instance
    assert ("idle/breathe", "out", "mix", "idle") in keys  # out of the instance
    assert ("idle/wander", "out", "idle/wander_filter", "in") in keys  # inside
    assert ("in_gaze_target", "value", "idle/blink", "gaze") in keys
    assert not any("idle" in (e.from_.node, e.to.node) for e in flat.edges)
    apu = result.apu
    mix = apu.steps[apu.index["mix"]]
    assert {w.port: apu.steps[w.src].node_id for w in mix.wires}["blink"] == "idle/eyelid_filter"


def test_an_unused_definition_is_fine_and_an_unknown_one_is_named(desk):
    doc = interactive()
    doc["subgraphs"] = {"spare": grouped()["subgraphs"]["idle"]}
    assert compile_program(doc, desk).ok
    doc = grouped(definition="idle")
    doc["nodes"][[n["id"] for n in doc["nodes"]].index("idle")]["params"]["subgraph"] = "idel"
    errs = errors(desk, doc)
    assert [e.code for e in errs] == ["unknown_subgraph"]  # one error: no knock-on edge errors
    assert errs[0].node == "idle" and "'idel'" in errs[0].message and "did you mean 'idle'" in errs[0].message
    assert errs[0].path.endswith(".params.subgraph")


def test_errors_inside_name_the_subgraph_inner_node_and_port(desk):
    doc = grouped()
    sub = doc["subgraphs"]["idle"]
    k = [n["id"] for n in sub["nodes"]].index("breathe")
    sub["nodes"][k]["params"]["amplitude"] = 99
    [err] = errors(desk, doc)
    assert err.code == "invalid_param" and err.node == "idle/breathe" and err.port == "amplitude"
    assert err.path == f"subgraphs.idle.nodes[{k}].params.amplitude"
    assert err.render().startswith("[invalid_param] idle/breathe.amplitude:")


def test_missing_exposed_port(desk):
    doc = grouped()
    sub = doc["subgraphs"]["idle"]
    sub["inputs"][0]["port"] = "amplitud"  # breathe has no input 'amplitud'
    errs = errors(desk, doc)
    assert [e.code for e in errs] == ["unknown_port"]
    assert errs[0].node == "idle/breathe" and errs[0].port == "amplitud"
    assert errs[0].path == "subgraphs.idle.inputs[0].port" and "did you mean 'amplitude'" in errs[0].message
    doc = grouped()
    doc["subgraphs"]["idle"]["outputs"][0]["node"] = "breath"  # no such inner node
    errs = errors(desk, doc)
    assert errs[0].code == "unknown_exposed_port" and "no node 'breath'" in errs[0].message
    assert errs[0].path == "subgraphs.idle.outputs[0].node"
    doc = grouped()
    doc["edges"].append(
        {"from": {"node": "idle", "port": "nope"}, "to": {"node": "look_at_weight", "port": "b"}}
    )
    errs = errors(desk, doc)
    assert [e.code for e in errs] == ["unknown_exposed_port"]
    assert errs[0].node == "idle" and errs[0].port == "nope" and "breathe_out" in errs[0].message


def test_type_mismatch_through_an_exposed_port(desk):
    doc = grouped()
    edge = next(e for e in doc["edges"] if e["to"] == {"node": "idle", "port": "breathe_amplitude"})
    edge["from"] = {"node": "in_gaze_target", "port": "value"}  # a vec3 into a float
    errs = errors(desk, doc)
    assert [e.code for e in errs] == ["port_type_mismatch"]
    assert errs[0].node == "idle/breathe" and errs[0].port == "amplitude"
    assert errs[0].path == f"edges[{doc['edges'].index(edge)}]"


def test_recursion_is_an_error_naming_the_cycle(desk):
    doc = grouped()
    doc["subgraphs"]["a"] = {"nodes": [{"id": "inner", "type": "subgraph", "params": {"subgraph": "b"}}]}
    doc["subgraphs"]["b"] = {"nodes": [{"id": "deeper", "type": "subgraph", "params": {"subgraph": "a"}}]}
    doc["nodes"].append({"id": "loop", "type": "subgraph", "params": {"subgraph": "a"}})
    errs = errors(desk, doc)
    cyc = [e for e in errs if e.code == "subgraph_cycle"]
    assert len(cyc) == 1 and "a → b → a" in cyc[0].message and cyc[0].node == "loop/inner/deeper"
    assert cyc[0].path == "subgraphs.b.nodes[0].params.subgraph"
    doc["subgraphs"]["self"] = {"nodes": [{"id": "me", "type": "subgraph", "params": {"subgraph": "self"}}]}
    doc["nodes"].append({"id": "again", "type": "subgraph", "params": {"subgraph": "self"}})
    assert any("self → self" in e.message for e in errors(desk, doc))


def test_nested_subgraphs_flatten_with_paths(desk):
    doc = grouped()
    doc["subgraphs"]["outer"] = {
        "nodes": [{"id": "idle", "type": "subgraph", "params": {"subgraph": "idle"}}],
        "inputs": [
            {"name": "amp", "node": "idle", "port": "breathe_amplitude"},
            {"name": "gaze", "node": "idle", "port": "blink_gaze"},
        ],
        "outputs": [
            {"name": o["name"], "node": "idle", "port": o["name"]}
            for o in doc["subgraphs"]["idle"]["outputs"]
        ],
    }
    node = next(n for n in doc["nodes"] if n["id"] == "idle")
    node.update(id="life", params={"subgraph": "outer"})
    for e in doc["edges"]:
        for end in (e["from"], e["to"]):
            if end["node"] == "idle":
                end["node"] = "life"
                end["port"] = {"breathe_amplitude": "amp", "blink_gaze": "gaze"}.get(end["port"], end["port"])
    result = compile_program(doc, desk)
    assert result.ok, [e.render() for e in result.report.errors]
    assert "life/idle/breathe" in result.apu.index
    assert ("breath_amplitude", "value", "life/idle/breathe", "amplitude") in {
        e.key() for e in result.flat.edges
    }


def test_ids_inside_subgraphs_cannot_contain_a_slash(desk):
    doc = grouped()
    doc["subgraphs"]["idle"]["nodes"][0]["id"] = "a/b"
    assert any(e.code == "schema" and "cannot contain '/'" in e.message for e in errors(desk, doc))


# --- running ------------------------------------------------------------------------------------------


def test_frames_identical_to_the_same_blocks_written_flat(desk):
    a = EngineSession.create(desk, rate=100, program=grouped())
    b = EngineSession.create(desk, rate=100, program=flat_named())
    try:
        assert [s.node_id for s in a.engine.apu.steps] == [s.node_id for s in b.engine.apu.steps]
        fa = np.array([f.position for f in a.run_headless(400)])
        fb = np.array([f.position for f in b.run_headless(400)])
        assert fa.shape == fb.shape and np.ptp(fa, axis=0).max() > 0.01  # it moves
        np.testing.assert_array_equal(fa, fb)
    finally:
        a.engine.close()
        b.engine.close()


def test_live_patch_of_an_inner_param_and_round_trip(desk):
    session = EngineSession.create(desk, rate=100, program=grouped())
    try:
        block = session.engine.apu.block("idle/breathe")
        got = session.update_params("idle/breathe", {"frequency": 0.4})
        assert got["frequency"] == 0.4 and session.engine.apu.block("idle/breathe") is block
        assert block.params.frequency == 0.4
        doc = apu_to_program(session.engine.apu).to_json_dict()
        inner = next(n for n in doc["subgraphs"]["idle"]["nodes"] if n["id"] == "breathe")
        assert inner["params"]["frequency"] == 0.4 and doc["nodes"] == [
            n for n in Program.model_validate(grouped()).to_json_dict()["nodes"]
        ]
        # A PUT of the same document with a changed inner parameter keeps every block (parameter-only).
        doc2 = copy.deepcopy(doc)
        next(n for n in doc2["subgraphs"]["idle"]["nodes"] if n["id"] == "breathe")["params"]["frequency"] = (
            0.3
        )
        doc2["ui"] = {
            "comments": [{"id": "c1", "x": 0, "y": 0, "w": 300, "h": 200, "title": "Idle", "colour": "#446"}]
        }
        _, _kept = session.load_program(doc2)
        assert session.engine.apu.block("idle/breathe") is block and block.params.frequency == 0.3
        assert apu_to_program(session.engine.apu).to_json_dict()["ui"] == doc2["ui"]
    finally:
        session.engine.close()


def test_api_patch_profile_and_program_of_a_grouped_program(desk, tmp_path):
    session = EngineSession.create(desk, rate=100, program=grouped())
    session.library.folder = tmp_path
    try:
        with TestClient(create_app(session, frontend_dir=None)) as client:
            r = client.patch("/api/program/nodes/idle/breathe/params", json={"amplitude": 0.05})
            assert r.status_code == 200, r.text
            assert r.json()["params"]["amplitude"] == 0.05
            assert session.engine.apu.block("idle/breathe").params.amplitude == 0.05
            assert (
                client.patch("/api/program/nodes/idle/nope/params", json={"amplitude": 0.05}).status_code
                == 404
            )
            session.engine.run_ticks(30)
            profile = client.get("/api/profile").json()
            assert {f"idle/{i}" for i in IDLE} <= {n["node"] for n in profile["nodes"]}
            prog = client.get("/api/program").json()["program"]
            assert "idle" in prog["subgraphs"] and any(n["id"] == "idle" for n in prog["nodes"])
            assert client.post("/api/program/validate", json=prog).json()["valid"] is True
    finally:
        session.engine.close()


# --- the library -----------------------------------------------------------------------------------


def test_library_subgraphs_save_list_get_delete(desk, tmp_path):
    session = EngineSession.create(desk, rate=100, program=grouped())
    session.library.folder = tmp_path
    definition = grouped()["subgraphs"]["idle"]
    try:
        with TestClient(create_app(session, frontend_dir=None)) as client:
            assert client.get("/api/subgraphs").json() == []
            r = client.put("/api/subgraphs/idle", json=definition)
            assert r.status_code == 200, r.text
            assert (
                tmp_path / "subgraphs" / "idle.json"
            ).stat().st_mode & 0o777 == 0o644  # not mkstemp's 0600
            assert client.get("/api/subgraphs").json() == ["idle"]
            assert client.get("/api/subgraphs/idle").json()["outputs"] == definition["outputs"]
            bad = copy.deepcopy(definition)
            bad["nodes"][0]["type"] = "breeth"
            r = client.put("/api/subgraphs/bad", json=bad)
            assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_subgraph"
            assert r.json()["detail"]["report"]["errors"][0]["code"] == "unknown_block_type"
            r = client.put("/api/subgraphs/bad", json={"nodes": "nope"})
            assert r.status_code == 422
            nested = {"nodes": [{"id": "inner", "type": "subgraph", "params": {"subgraph": "idle"}}]}
            r = client.put("/api/subgraphs/bad", json=nested)
            assert (
                r.status_code == 422
                and "self-contained" in r.json()["detail"]["report"]["errors"][0]["message"]
            )
            assert client.get("/api/subgraphs").json() == ["idle"]
            assert client.delete("/api/subgraphs/idle").status_code == 200
            assert client.get("/api/subgraphs").json() == []
            assert client.get("/api/subgraphs/idle").status_code == 404
    finally:
        session.engine.close()


def test_a_hot_swap_keeps_the_state_of_inner_blocks(desk):
    session = EngineSession.create(desk, rate=100, program=grouped())
    try:
        session.run_headless(50)
        phase = session.engine.apu.block("idle/breathe").state
        doc = grouped()
        doc["nodes"].append(
            {"id": "spare", "type": "sine", "params": {"dofs": ["head_yaw"], "amplitude": 0.01}}
        )
        _, kept = session.load_program(doc)  # a structural change: a new APU
        assert {f"idle/{i}" for i in IDLE} <= set(kept)
        assert session.engine.apu.block("idle/breathe").state == phase
    finally:
        session.engine.close()


def test_grouping_a_running_program_keeps_every_block_going(desk):
    """Hot-swapping the flat program for the grouped one: each grouped block takes over the state of
    the block it was (`breathe` -> `idle/breathe`), so the robot moves on exactly as if nothing had
    changed (random generators included)."""
    a = EngineSession.create(desk, rate=100, program=interactive())
    b = EngineSession.create(desk, rate=100, program=interactive())
    try:
        fa = list(a.run_headless(150))
        _, kept = a.load_program(grouped())
        assert set(kept) == {s.node_id for s in a.engine.apu.steps}  # every block, grouped ones included
        fa += list(a.run_headless(250))
        fb = list(b.run_headless(400))
        # the program's own frames are the same; the robot's only through the swap's (blended) transition
        np.testing.assert_array_equal(np.array([f.program for f in fa]), np.array([f.program for f in fb]))
        np.testing.assert_allclose(
            np.array([f.position for f in fa]), np.array([f.position for f in fb]), atol=1e-3
        )
        # and back: ungrouped again, the blocks keep going too
        _, kept = a.load_program(interactive())
        assert set(IDLE) <= set(kept)
    finally:
        a.engine.close()
        b.engine.close()


def test_duplicate_ids_inside_a_definition_point_into_it(desk):
    doc = grouped()
    nodes = doc["subgraphs"]["idle"]["nodes"]
    nodes.append(dict(nodes[0]))
    [err] = errors(desk, doc)
    assert err.code == "duplicate_node" and err.node == f"idle/{nodes[0]['id']}"
    assert err.path == f"subgraphs.idle.nodes[{len(nodes) - 1}].id"
    assert f"(subgraphs.idle.nodes[0] and subgraphs.idle.nodes[{len(nodes) - 1}])" in err.message


def test_a_patch_inside_a_subgraph_edits_the_definition_for_every_instance(desk):
    doc = grouped()
    idle = next(n for n in doc["nodes"] if n["id"] == "idle")
    doc["nodes"].append({**copy.deepcopy(idle), "id": "idle2"})  # a second instance, unwired: it still runs
    session = EngineSession.create(desk, rate=100, program=doc)
    try:
        blocks = [session.engine.apu.block(f"{i}/breathe") for i in ("idle", "idle2")]
        got = session.update_params("idle2/breathe", {"amplitude": 0.05})
        assert got["amplitude"] == 0.05
        assert [b.params.amplitude for b in blocks] == [0.05, 0.05]  # the same tick, nothing rebuilt
        assert [session.engine.apu.block(f"{i}/breathe") for i in ("idle", "idle2")] == blocks
        written = next(n for n in session.program.subgraphs["idle"].nodes if n.id == "breathe")
        assert written.params["amplitude"] == 0.05  # GET /api/program and a save show the edit
        assert all(session.flat.node(f"{i}/breathe").params["amplitude"] == 0.05 for i in ("idle", "idle2"))
    finally:
        session.engine.close()
