"""Graph -> compiled APU -> graph is lossless: params (live ones included), ui, inputs, edges."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from backend.engine.apu import APU
from backend.graph.compiler import compile_or_raise
from backend.graph.roundtrip import RoundTripError, apu_to_json, apu_to_program
from backend.graph.schema import Program
from backend.session import EngineSession

VALID = sorted((Path(__file__).parent / "golden" / "valid").glob("*.json"))


@pytest.mark.parametrize("path", VALID, ids=lambda p: p.stem)
def test_golden_programs_come_back_unchanged(desk, path):
    text = path.read_text()
    apu = compile_or_raise(text, desk).apu
    back = apu_to_program(apu)
    assert back == Program.model_validate_json(text)
    assert back is not apu.source  # a copy: editing it does not touch the running program
    # Compiling what came back gives the same program again.
    again = compile_or_raise(apu_to_json(apu), desk).apu
    assert [(s.node_id, s.type_name, s.wires) for s in again.steps] == [
        (s.node_id, s.type_name, s.wires) for s in apu.steps
    ]
    assert json.loads(apu_to_json(apu)) == back.to_json_dict()


def test_live_parameter_changes_are_saved(desk):
    text = (Path(__file__).parent / "golden" / "valid" / "level2_layers.json").read_text()
    session = EngineSession.create(desk, program_text=text)
    list(session.run_headless(10))
    session.update_params("breath", {"frequency": 0.6})
    session.update_params("look", {"values": {"head_yaw": -0.3}})
    back = apu_to_program(session.engine.apu)
    assert back.node("breath").params["frequency"] == 0.6
    assert back.node("breath").params["dofs"] == ["neck_pitch", "head_pitch"]
    assert back.node("look").params["values"] == {"head_yaw": -0.3}
    original = Program.model_validate_json(text)
    assert [n.ui for n in back.nodes] == [n.ui for n in original.nodes]
    assert back.inputs == original.inputs and back.edges == original.edges and back.ui == original.ui
    # A change made on the block directly (not through the session) is seen too.
    block = session.engine.apu.block("mixer")
    new = block.Params.model_validate(
        {
            "layers": [
                {"name": "base"},
                {"name": "idle", "mode": "additive"},
                {"name": "look", "weight": 0.25, "active": False},
            ]
        }
    )
    block.update_params(new)
    layers = apu_to_program(session.engine.apu).node("mixer").params["layers"]
    assert layers[2] == {"name": "look", "weight": 0.25, "active": False}
    # What came back runs and behaves like the live program.
    fresh = EngineSession.create(desk, program=apu_to_program(session.engine.apu))
    assert fresh.engine.apu.block("breath").params == session.engine.apu.block("breath").params
    assert fresh.engine.apu.block("mixer").params == new


def test_an_apu_without_a_source_cannot_be_saved(desk):
    apu = compile_or_raise(
        (Path(__file__).parent / "golden" / "valid" / "level0_rest.json").read_text(), desk
    ).apu
    bare = APU(apu.steps, apu.output, apu.level, apu.stage1_tap)
    with pytest.raises(RoundTripError):
        apu_to_program(bare)
