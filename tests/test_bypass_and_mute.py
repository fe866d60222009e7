"""Bypass and mute, saved in the program. A node with `"bypass": true` runs as a pass-through of its first
frame input, keeps its parameters and wires in the document, and the robot's guard can never be bypassed.
A layer's written `active` (the editor's mute) fades the layer on a live edit and across a swap."""

from __future__ import annotations

import json
from pathlib import Path

from backend.engine.blocks import BLOCKS
from backend.graph.compiler import compile_program
from backend.graph.roundtrip import apu_to_program

GOLDEN = Path(__file__).parent / "golden"


def _program(**bypass: bool) -> dict:
    doc = json.loads((GOLDEN / "valid" / "level3_safe_idle.json").read_text())
    for node in doc["nodes"]:
        if node["id"] in bypass:
            node["bypass"] = bypass[node["id"]]
    return doc


def test_a_bypassed_mask_passes_its_input_through(desk):
    names = list(desk.channel_names)
    others = [i for i, n in enumerate(names) if not n.startswith("ear_")]
    outs = []
    for bypass in (True, False):
        doc = _program(ears_only=bypass)
        for edge in doc["edges"]:  # the mask gets the whole rest pose, so cutting it to the ears shows
            if edge["to"] == {"node": "ears_only", "port": "in"}:
                edge["from"] = {"node": "rest", "port": "out"}
        apu = compile_program(doc, desk).apu
        assert apu is not None and bool(type(apu.block("ears_only")).bypassed) is bypass
        apu.tick(0.005)
        outs.append((apu.signal_value("rest", "out"), apu.signal_value("ears_only", "out")))
    (rest, passed), (_, masked) = outs
    assert passed is rest  # the very frame, unchanged
    assert passed.mask[others].all() and not masked.mask[others].any()


def test_bypass_is_kept_in_the_document_and_false_is_omitted(desk):
    result = compile_program(_program(ears_only=True, breath=False), desk)
    assert result.apu is not None
    nodes = {n["id"]: n for n in apu_to_program(result.apu).to_json_dict()["nodes"]}
    assert nodes["ears_only"]["bypass"] is True
    assert "bypass" not in nodes["breath"] and "bypass" not in nodes["mixer"]


def test_sources_outputs_and_the_safety_limiter_cannot_be_bypassed(desk):
    report = compile_program(_program(rest=True, limit=True, output=True), desk).report
    by_node = {e.node: e for e in report.errors if e.code == "cannot_bypass"}
    assert set(by_node) == {"rest", "limit", "output"}
    assert "guards the robot" in by_node["limit"].message
    assert by_node["rest"].path.endswith(".bypass")


def test_the_catalog_says_which_blocks_can_be_bypassed():
    entries = {k: cls.describe()["bypassable"] for k, cls in BLOCKS.items()}
    assert entries["motion_filter"] and entries["layer_mixer"] and entries["mask"] and entries["ik"]
    assert not entries["safety_limiter"] and not entries["output"] and not entries["sine"]
    assert not entries["lfo"]


def test_a_bypassed_filter_still_reports_bad_parameters(desk):
    doc = _program(ears_only=True)
    node = next(n for n in doc["nodes"] if n["id"] == "ears_only")
    node["params"] = {"dofs": ["no_such_dof"]}
    report = compile_program(doc, desk).report
    assert any(e.node == "ears_only" and e.code == "unknown_dof" for e in report.errors)


def _mute_ears(doc: dict) -> dict:
    mixer = next(n for n in doc["nodes"] if n["id"] == "mixer")
    mixer["params"]["layers"][2]["active"] = False
    return doc


def test_a_layer_muted_in_the_program_fades_out_on_a_live_edit(desk):
    apu = compile_program(_program(), desk).apu
    assert apu is not None
    mixer = apu.block("mixer")
    for _ in range(10):
        apu.tick(0.005)
    muted = type(mixer.params).model_validate(_mute_ears(_program())["nodes"][5]["params"])
    mixer.update_params(muted)
    apu.tick(0.005)
    level = mixer.state.fade_level[2]
    assert mixer.state.fade_target[2] == 0.0 and 0.9 < level < 1.0  # fading (1 s), no jump
    for _ in range(250):
        apu.tick(0.005)
    assert mixer.state.fade_level[2] == 0.0


def test_a_layer_muted_in_the_program_fades_out_across_a_swap_and_commands_still_win(desk):
    old = compile_program(_program(), desk).apu
    assert old is not None
    old.block("mixer").set_layer_active("breathing", False)  # a run-time command: kept over a swap
    for _ in range(10):
        old.tick(0.005)
    new = compile_program(_mute_ears(_program()), desk).apu
    assert new is not None
    new.adopt_state_from(old)
    state = new.block("mixer").state
    assert state.fade_target[2] == 0.0 and state.fade_level[2] == 1.0  # fades from where it was
    assert state.fade_target[1] == 0.0  # breathing: the command's mute, not the document's default
