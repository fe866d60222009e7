"""Signal blocks in the compiled core (backend/engine/core/signal_ops.py): the emotion and the math run in
the kernel and drive the parameters of compiled blocks there, and what they publish to Python readers is
what their own ticks return, through random wirings, commands, edits and the blocks' own timed ticks."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_compiled_core import assert_same_frames, frame_tuple, segments, session_for

from backend.engine.compiled.signals import MATH_OPS
from backend.engine.embodiment import load_embodiment
from backend.graph.builder import ProgramBuilder

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"
EMOTION_PORTS = ("speed", "amplitude", "posture_offset", "posture", "valence", "arousal")


@pytest.fixture(scope="module")
def robot():
    return load_embodiment("nutty_desk")


def signals(session, nodes: dict[str, tuple[str, ...]]) -> list:
    """Every output of the signal nodes, as Python readers see them (a zero's sign kept apart)."""
    out = []
    for node, ports in nodes.items():
        for port in ports:
            v = session.engine.apu.signal_value(node, port)
            out.append((v, math.copysign(1.0, v)) if isinstance(v, float) else v)
    return out


@st.composite
def signal_program(draw) -> tuple[dict, dict[str, tuple[str, ...]]]:
    """Two exposed inputs into an emotion, two maths of any op fed by the emotion, an input or an LFO (a
    Python signal), and what they drive: a breath's amplitude and a gain/offset in the kernel, an LFO's
    frequency in Python, and sometimes a mixer's weight (which keeps its source in Python)."""
    b = ProgramBuilder("signals")
    x = b.expose("x", "float", default=draw(st.sampled_from([0.0, 0.3, -0.7])))
    y = b.expose("y", "float", default=draw(st.sampled_from([0.0, -0.2, 0.9])))
    emo = b.node(
        "emotion",
        "emo",
        smoothing=draw(st.sampled_from([0.0, 0.05, 0.5])),
        hysteresis=draw(st.sampled_from([0.0, 0.05, 0.4])),
    )
    b.connect(x, emo, "value", "valence").connect(y, emo, "value", "arousal")
    lfo = b.node("lfo", "lfo", frequency=0.7, amplitude=0.4, offset=0.2)
    sources = [(emo, p) for p in ("speed", "amplitude", "posture_offset", "valence", "arousal")]
    sources += [(x, "value"), (lfo, "value")]
    maths = []
    for name in ("m1", "m2"):
        op = draw(st.sampled_from(MATH_OPS))
        params = {"op": op, "b": draw(st.sampled_from([0.0, -0.0, 0.5, -2.0, 1e308]))}
        if op in ("map_range", "smoothstep"):
            params |= {"in_min": -1.0, "in_max": draw(st.sampled_from([0.5, 2.0])), "out_min": 0.01}
            params["clamped"] = draw(st.booleans())
        m = b.node("math", name, **params)
        src, port = draw(st.sampled_from(sources))
        b.connect(src, m, port, "a")
        if draw(st.booleans()):
            src, port = draw(st.sampled_from(sources))
            b.connect(src, m, port, "b")
        maths.append(m)
        sources.append((m, "value"))
    breathe = b.node("breathe", "breathe", amplitude=0.04, frequency=0.8)
    go = b.node("gain_offset", "go", gain=1.0, offset=0.0)
    wave = b.node("sine", "wave", amplitude=0.2, frequency=0.9)
    b.chain(wave, go)
    reader = b.node("lfo", "reader", frequency=0.5, amplitude=0.3)
    b.connect(maths[1], reader, "value", "frequency")  # a Python block reading a compiled signal...
    sources.append((reader, "value"))  # ...and driving a compiled one through its `pre`
    for dst, port in ((breathe, "amplitude"), (breathe, "frequency"), (go, "gain"), (go, "offset")):
        if draw(st.booleans()):
            src, src_port = draw(st.sampled_from(sources))
            b.connect(src, dst, src_port, port)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}, {"name": "b", "mode": "additive"}])
    b.connect(go, mix, "out", "a").connect(breathe, mix, "out", "b")
    if draw(st.booleans()):
        b.connect(maths[0], mix, "value", "b_weight")  # the mixer reads it in Python: m1 stays Python
    b.chain(mix, b.output())
    return b.to_dict(), {"emo": EMOTION_PORTS, "m1": ("value",), "m2": ("value",), "reader": ("value",)}


INPUTS = (0.0, -0.0, 0.25, -1.0, 1.0, 0.8, 5.0, 1e300)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    built=signal_program(),
    script=st.lists(
        st.tuples(st.integers(0, 59), st.sampled_from(["x", "y"]), st.sampled_from(INPUTS)), max_size=6
    ),
    edit_at=st.integers(0, 59),
    every=st.sampled_from([3, 10**9]),
)
def test_random_signal_wirings_agree(monkeypatch, robot, built, script, edit_at, every):
    prog, nodes = built
    runs, seen = {}, {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, prog, core)
        session.engine.apu.cook.every = every  # the blocks' own ticks between the kernel's, or none
        frames, values = [], []
        for k in range(60):
            for at, name, value in script:
                if at == k:
                    session.execute({"type": "set_input", "name": name, "value": value})
            if k == edit_at:
                session.update_params("emo", {"droop": 0.35, "smoothing": 0.1})
                session.update_params("m2", {"b": 0.25})
            frames.append(frame_tuple(session.engine.tick()))
            values.append(signals(session, nodes))
        runs[core], seen[core] = frames, values
    assert_same_frames(runs[True], runs[False])
    assert seen[True] == seen[False]


def test_the_interactive_emotion_drives_its_blocks_in_the_kernel(monkeypatch, robot):
    """The emotion and the breath's math run in the kernel; the breath and the mood take them there,
    without a `pre`; the look-at's weight math, read by the IK's own `pre`, stays a Python block."""
    prog = json.loads((PROGRAMS / "interactive.json").read_text())
    session = session_for(monkeypatch, robot, prog, True)
    engine = session.engine
    engine.apu.cook.every = 10**9
    compiled = {node for seg in segments(session) for node in seg}
    assert {"emotion", "breath_amplitude"} <= compiled and "look_at_weight" not in compiled
    ops = {op.block.node_id: op for op in engine.apu.core.ops}
    assert not ops["breathe"].needs_pre() and not ops["mood"].needs_pre()
    assert [port for port, _ in ops["breathe"].drive_wires] == ["amplitude"]
    engine.run_ticks(5)
    session.execute({"type": "set_input", "name": "valence", "value": -0.9})
    outs = []
    for _ in range(1000):  # 10 s: the emotion moves, then lands on its target (~7 s)
        engine.tick()
        outs.append(engine.apu.results[ops["emotion"].step])
    emotion = engine.apu.block("emotion")
    assert emotion.state.v == -0.9 and outs[-1]["valence"] == -0.9 and outs[-1]["posture"] == "sad"
    assert outs[-1] is outs[-2]  # settled: the same outputs, the same object (quiet readers see it)
    amp = engine.apu.signal_value("breath_amplitude", "value")
    assert amp == pytest.approx(outs[-1]["amplitude"] * 0.035)
    assert engine.apu.block("breath_amplitude").state.last == amp
    breathe = ops["breathe"]
    assert engine.apu.core.arena.S[breathe.s + 1] == amp  # the breath's amplitude, driven in the kernel
    assert np.isfinite(engine.last_frame.position).all()


def test_exposed_inputs_are_read_when_set_not_ticked(monkeypatch, robot):
    prog = json.loads((PROGRAMS / "interactive.json").read_text())
    session = session_for(monkeypatch, robot, prog, True)
    engine = session.engine
    engine.apu.cook.every = 10**9
    block = engine.apu.block("in_valence")
    ticks = []
    block.tick = lambda dt, inputs: ticks.append(dt) or {}  # type: ignore[method-assign]  # a probe
    engine.run_ticks(5)
    i = engine.apu.index["in_valence"]
    held = engine.apu.results[i]
    engine.run_ticks(5)
    assert engine.apu.results[i] is held  # no input changed: nothing read, nothing made
    session.execute({"type": "set_input", "name": "valence", "value": -0.4})
    engine.tick()
    assert engine.apu.results[i] == {"value": -0.4} and engine.apu.results[i] is not held
    session.execute({"type": "set_input", "name": "arousal", "value": 0.2})  # another input changed
    held = engine.apu.results[i]
    engine.tick()
    assert engine.apu.results[i] is held  # its own value is the same object: its readers stay asleep
    assert ticks == []  # the core read the values; the block never ticked
    # and the emotion took the valence (read as a probe reads it: no Python step reads the emotion here,
    # so the core publishes its outputs and state on demand)
    assert engine.apu.signal_value("emotion", "valence") != 0.0
    assert engine.apu.block("emotion").state.v == engine.apu.signal_value("emotion", "valence")


def test_input_values_count_every_change():
    from backend.engine.blocks.input_values import InputValues  # lazy: the one class tested here

    values = InputValues({"a": 1.0})
    seen = [values.version]
    for change in (
        lambda: values.__setitem__("a", 2.0),
        lambda: values.update(b=1.0),
        lambda: values.setdefault("c", 0.0),
        lambda: values.pop("c"),
        lambda: values.__delitem__("b"),
        lambda: values.__ior__({"d": 1}),
        lambda: values.popitem(),
        lambda: values.clear(),
    ):
        change()
        seen.append(values.version)
    assert seen == sorted(set(seen)) and len(seen) == 9  # each one counted


def test_lazy_signals_hand_their_state_to_swaps_edits_and_probes(monkeypatch, robot):
    """No Python step reads the interactive program's emotion or breath amplitude: the core publishes
    them, and writes their state back into the blocks, only when something asks. A hot swap adopting the
    blocks' state mid-smoothing, an edit of the emotion and the probes must all see the kernel's state
    (no blocks' own ticks in between to bring it up to date)."""
    interactive = json.loads((PROGRAMS / "interactive.json").read_text())
    grown = {
        **interactive,
        "nodes": [*interactive["nodes"], {"id": "spare", "type": "rest_pose", "params": {}}],
    }
    runs, probes = {}, {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, interactive, core)
        engine = session.engine
        engine.apu.cook.every = 10**9
        if core:
            lazy = {
                op.block.node_id: op.arena.S[op.s + op.lazy_slot]
                for op in engine.apu.core.ops
                if hasattr(op, "lazy_slot")
            }
            assert lazy == {"emotion": 1.0, "breath_amplitude": 1.0}
        frames, seen = [], []
        for k in range(160):
            if k == 5:
                session.execute({"type": "set_emotion", "valence": -0.7, "arousal": 0.8})
            if k == 40:
                session.load_program(grown)  # a new program, which adopts the emotion's state mid-smoothing
                assert engine.apu.block("spare") is not None
            if k == 60:
                session.update_params("emotion", {"smoothing": 0.3})
            if k == 90:
                session.execute({"type": "set_emotion", "valence": 0.6, "arousal": -0.5})
            frames.append(frame_tuple(engine.tick()))
            if k % 9 == 0:
                seen.append(engine.apu.signal_values([("emotion", "valence"), ("emotion", "posture")]))
        runs[core], probes[core] = frames, seen
    assert_same_frames(runs[True], runs[False])
    assert probes[True] == probes[False]


def test_an_edit_keeps_the_state_a_lazy_signal_stepped(monkeypatch, robot):
    """An emotion that only drives a pose's offset in the kernel publishes nothing while it moves; an edit
    of its parameters binds it again, and the state it had stepped must carry on, not the block's older
    copy."""
    b = ProgramBuilder("lazy")
    valence, arousal = b.expose("valence", "float", default=0.0), b.expose("arousal", "float", default=0.0)
    emotion = b.node("emotion", "emotion", smoothing=0.8)
    pose = b.node("rest_pose", "pose", dofs=["neck_pitch", "head_pitch"])
    mood = b.node("gain_offset", "mood", dofs=["neck_pitch", "head_pitch"])
    b.connect(valence, emotion, "value", "valence").connect(arousal, emotion, "value", "arousal")
    b.connect(emotion, mood, "posture_offset", "offset").chain(pose, mood, b.output())
    runs = {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, b.to_dict(), core)
        session.engine.apu.cook.every = 10**9
        frames = []
        for k in range(120):
            if k == 3:
                session.execute({"type": "set_input", "name": "arousal", "value": 0.9})
            if k == 50:
                session.update_params("emotion", {"smoothing": 0.2, "droop": 0.3})
            frames.append(frame_tuple(session.engine.tick()))
        runs[core] = frames
    assert_same_frames(runs[True], runs[False])
    pitch = [f[0][robot.dof("head_pitch").channels.start] for f in runs[True]]
    assert max(pitch) - min(pitch) > 0.01  # the emotion moved the pose: the comparison covered it
