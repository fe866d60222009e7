"""The bundled programs of the default robot: they validate, run headless with their commands, and the
final motion respects the robot's limits (position, velocity, acceleration and jerk)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from backend.engine.trajectory import analyze
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"
SCRIPT = [  # (time s, command): an AI driving the interactive program
    (0.5, {"type": "play_clip", "clip": "wave", "layer": "gesture"}),
    (1.0, {"type": "set_gaze", "target": [0.8, 0.6, 0.5]}),
    (3.5, {"type": "play_clip", "clip": "surprised"}),
    (4.0, {"type": "set_emotion", "valence": 0.8, "arousal": 0.7}),
    (5.0, {"type": "say", "text": "hello there, I am Nutty"}),
    (6.0, {"type": "play_clip", "clip": "nod"}),
    (6.5, {"type": "set_gaze", "target": [0.9, -0.7, 0.1]}),
    (7.5, {"type": "go_posture", "posture": "sad"}),
    (8.0, {"type": "play_clip", "clip": "shake"}),
    (8.2, {"type": "set_led", "colour": [1, 0, 0]}),
    (8.4, {"type": "set_face", "expression": "grin"}),
    (9.0, {"type": "play_sound", "sound": "chirp"}),
]


def run_program(desk, name, seconds=10.0, script=()):
    session = EngineSession.create(
        desk, rate=100, program=json.loads((PROGRAMS / f"{name}.json").read_text())
    )
    notes = []
    session.on_note(notes.append)
    frames, pending = [], list(script)
    for k in range(int(seconds * 100)):
        while pending and pending[0][0] <= k / 100:
            session.execute(pending.pop(0)[1])
        frames.extend(session.run_headless(1))
    return session, frames, notes


def assert_within_limits(desk, frames):
    cont = [d for d in desk.dofs if d.type.value == "continuous"]
    idx = [d.channels.start for d in cont]
    pos = np.array([f.position[idx] for f in frames])
    assert np.all(pos >= desk.min[idx] - 1e-9) and np.all(pos <= desk.max[idx] + 1e-9)
    a = analyze(pos, 100.0, desk.vel_limit[idx], desk.acc_limit[idx], desk.jerk_limit[idx])
    bad = {d.name: s for d, s in zip(cont, a.summary) if s["ok"] < len(pos)}
    assert not bad, bad
    return pos, cont


@pytest.mark.parametrize("name", ["idle", "greet", "interactive", "breathe-anything"])
def test_bundled_programs_run_within_the_robot_limits(desk, name):
    session, frames, _ = run_program(desk, name, script=SCRIPT if name == "interactive" else ())
    pos, cont = assert_within_limits(desk, frames)
    moving = [d.name for d, r in zip(cont, np.ptp(pos, axis=0)) if r > 0.01]
    assert len(moving) >= 3, moving  # alive, not a statue
    assert session.engine.apu.level == (2 if name == "idle" else 3)


def test_interactive_program_answers_an_ai(desk):
    _session, frames, notes = run_program(desk, "interactive", seconds=10.0, script=SCRIPT)
    done = {(n.get("clip") or n.get("posture") or n.get("text")) for n in notes if n["event"] == "completed"}
    assert {"wave", "surprised", "nod", "sad"} <= done
    cancelled = {n.get("clip") for n in notes if n["event"] == "cancelled"}
    assert "shake" not in cancelled
    kinds = [(e.dof, e.kind) for f in frames for e in f.events]
    assert ("speech", "say") in kinds and ("sound", "sound") in kinds
    i = desk.channel_index
    yaw = np.array([f.position[i["body_yaw"]] + f.position[i["head_yaw"]] for f in frames])
    assert yaw[300] > 0.3 and yaw[900] < -0.3  # looked left at the first target, right at the second
    led = frames[-1].position[desk.dof("eye_leds").channels]
    assert led[0] > 0.5 and led[2] < 0.3  # set_led red reached the eyes through the led block
    mouth = desk.dof("mouth")
    assert frames[-1].position[mouth.channels.start] == mouth.options.index("grin")


def test_breathe_anything_runs_on_another_robot():
    from test_embodiment import _example_robot_data

    from backend.engine.embodiment import load_embodiment

    panda = load_embodiment(f"{_example_robot_data()}/panda_description/urdf/panda.urdf")
    _session, frames, _ = run_program(panda, "breathe-anything", seconds=3.0)
    pos = np.array([f.position for f in frames])
    assert np.ptp(pos[:, panda.continuous_mask], axis=0).max() > 0.005
    assert_within_limits(panda, frames)


@pytest.mark.parametrize("name", ["idle", "greet", "interactive", "breathe-anything"])
def test_the_safety_net_leaves_the_bundled_programs_unchanged(desk, name):
    """The bundled programs respect the robot's limits themselves: the engine's safety net passes them
    through bit for bit (idle starts away from the rest pose the robot is assumed to start in, so its
    first ticks are eased in)."""
    script = SCRIPT if name == "interactive" else ()
    with_net, frames, _ = run_program(desk, name, script=script)
    without = [f.program for f in frames]  # the program's own frames, before the net
    start = 50 if name == "idle" else 0
    assert all(np.array_equal(f.position, p) for f, p in zip(frames[start:], without[start:]))
    assert with_net.engine.safety.stats()["corrected_ticks"] <= start
