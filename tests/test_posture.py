"""The posture block: eased moves to named postures, events, enum switching, cancellation."""

from __future__ import annotations

import numpy as np
import pytest

from backend.commands.serve import builtin_idle
from backend.engine.blocks.posture import ease
from backend.session import EngineSession


@pytest.mark.parametrize(
    "name",
    ["linear", "sine_in_out", "quad_in_out", "cubic_in_out", "quint_in_out", "back_out", "elastic_out"],
)
def test_easings_start_at_0_and_end_at_1(name):
    assert ease(name, 0.0) == pytest.approx(0.0, abs=1e-9)
    assert ease(name, 1.0) == pytest.approx(1.0)


def test_slow_in_out_and_overshoot_shapes():
    assert ease("sine_in_out", 0.1) < 0.1 and ease("sine_in_out", 0.9) > 0.9  # slow in, slow out
    assert max(ease("back_out", u / 100) for u in range(101)) > 1.05  # follow-through overshoot


def test_go_posture_moves_with_events_and_switches_the_mouth_half_way(desk):
    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    notes = []
    session.on_note(notes.append)
    list(session.run_headless(5))
    session.execute({"type": "go_posture", "posture": "happy", "duration": 1.0, "id": "p1"})
    mouth = desk.channel_index["mouth"]
    ears = desk.channel_index["ear_left"]
    frames = list(session.run_headless(160))
    assert [n["event"] for n in notes if n.get("command_id") == "p1"] == ["started", "completed"]
    mouths = [f.stage1[mouth] for f in frames]
    assert mouths[20] == 0 and mouths[80] == desk.dof("mouth").options.index("smile")
    ear = np.array([f.stage1[ears] for f in frames])
    assert ear[-1] == pytest.approx(0.55, abs=0.05)  # happy ears (breathing adds a little)
    assert np.all(np.diff(ear[:100]) > -0.02)  # a smooth rise, no jump


def test_a_new_posture_cancels_the_running_move(desk):
    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    notes = []
    session.on_note(notes.append)
    session.execute({"type": "go_posture", "posture": "sad", "id": "a"})
    list(session.run_headless(30))
    session.execute({"type": "go_posture", "posture": "surprised", "id": "b"})
    list(session.run_headless(200))
    assert ("a", "cancelled") in [(n.get("command_id"), n["event"]) for n in notes]
    assert ("b", "completed") in [(n.get("command_id"), n["event"]) for n in notes]


def test_unknown_posture_is_a_clear_error(desk):
    from backend.control import CommandError

    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    with pytest.raises(CommandError, match="no posture 'ecstatic'"):
        session.execute({"type": "go_posture", "posture": "ecstatic"})
