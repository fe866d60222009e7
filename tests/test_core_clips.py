"""The compiled core's clip player (backend/engine/core/clip_ops.py) plays what the block's own ticks
play: frame for frame (within 1e-9), with the same notes in the same ticks and the same `weight`,
`playing` and `time` outputs, through every way a clip starts, plays, turns and ends: a trigger's rising
edge, autoplay, a queued play, a replacing crossfade, a seek, an anchor warp, clip events, loop and
ping-pong, a speed wired from Python or driven in the kernel by an emotion, a held clip, a stop with a
fade, a live edit and a reset."""

from __future__ import annotations

import numpy as np
import pytest
from test_clip_player import RAMP  # an absolute clip (not relative to rest) with an enum track and an event
from test_compiled_core import assert_same_frames, frame_tuple, program, session_for

from backend.engine.blocks.clip_player import smooth_step
from backend.graph.builder import ProgramBuilder


def clips_program() -> dict:
    b = ProgramBuilder("clips")
    speed = b.expose("speed", "float", default=1.0)
    trig = b.expose("trig", "bool", default=False)
    valence, arousal = b.expose("valence", "float", default=0.0), b.expose("arousal", "float", default=0.0)
    emotion = b.node("emotion", "emotion")
    one = b.node("clip_player", "one", clip="wave", crossfade=0.3, release=0.4)
    loop = b.node("clip_player", "loop", clip="shake", autoplay=True, mode="loop")
    held = b.node("clip_player", "held", clip="happy", hold=True, dofs=["ear_*", "head_*"])
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}, {"name": "b"}, {"name": "c"}])
    b.connect(speed, one, "value", "speed").connect(trig, one, "value", "trigger")
    b.connect(valence, emotion, "value", "valence").connect(arousal, emotion, "value", "arousal")
    b.connect(emotion, held, "speed", "speed")  # driven in the kernel
    b.connect(one, mix, "out", "a").connect(loop, mix, "out", "b").connect(held, mix, "out", "c")
    b.connect(loop, mix, "weight", "b_weight")  # a signal output read: worked out every tick
    b.chain(mix, b.output())
    return b.to_dict()


INPUT = "input"
SCRIPT: dict[int, tuple] = {
    3: (INPUT, "trig", True),  # a rising edge plays `one`'s clip
    8: (INPUT, "trig", False),
    30: ("one", "play", {"clip": "nod", "if_busy": "queue", "speed": 1.7, "command_id": "q"}),
    45: ("one", "play", {"clip": "ramp", "document": RAMP, "crossfade": 0.2}),  # replaces, crossfading
    70: ("one", "seek", {"t": 0.1}),
    90: ("one", "play", {"clip": "ramp", "document": RAMP, "anchors": {"mid": 1.2}}),
    110: ("one", "seek", {"t": 0.3}),  # leaves the warp behind
    150: ("one", "play", {"clip": "ramp", "document": RAMP, "mode": "ping_pong", "speed": 2.5}),
    170: (INPUT, "speed", 5.0),  # (the wired speed wins over the play's): bounces at both ends
    200: (INPUT, "speed", 3.0),
    230: ("one", "stop", {"fade": 0.3}),
    250: ("one", "play", {"clip": "ramp", "document": RAMP, "mode": "loop"}),
    300: ("edit", "one", {"crossfade": 0.1}),
    320: ("one", "stop", {}),
    330: (INPUT, "arousal", 0.9),
    340: ("held", "play", {}),
    380: ("loop", "stop", {"fade": 0.2}),
    400: (INPUT, "trig", True),
    420: ("held", "stop", {}),
    460: ("reset", "held"),
    470: ("held", "play", {"clip": "sad"}),
}


def carry_out(session, step: tuple) -> None:
    """One step of SCRIPT, at a tick boundary."""
    engine, kind = session.engine, step[0]
    if kind == INPUT:
        engine.call(lambda: engine.ctx.inputs.__setitem__(step[1], step[2]))
    elif kind == "edit":
        session.update_params(step[1], step[2])
    elif kind == "reset":
        engine.call(lambda: engine.apu.block(step[1]).reset())
    else:
        engine.call(lambda: engine.apu.block(kind).handle(step[1], dict(step[2])))


PROBES = [(node, port) for node in ("one", "loop", "held") for port in ("weight", "playing", "time")]


@pytest.mark.parametrize("every", [7, 10**9])
def test_clip_players_agree_with_their_own_ticks_through_every_way_a_clip_plays(monkeypatch, desk, every):
    runs, notes, probes = {}, {}, {}
    for core in (True, False):
        session = session_for(monkeypatch, desk, clips_program(), core)
        engine = session.engine
        engine.apu.cook.every = every  # the blocks' own ticks between the core's, or never
        notes[core] = []
        session.on_note(lambda n, seen=notes[core], e=engine: seen.append((e.seq, n)))
        frames, values = [], []
        for k in range(520):
            if k in SCRIPT:
                carry_out(session, SCRIPT[k])
            frames.append(frame_tuple(engine.tick()))
            values.append(engine.apu.signal_values(PROBES))
        runs[core], probes[core] = frames, values
        if core:
            ops = {op.block.node_id for op in engine.apu.core.ops}
            assert {"one", "loop", "held"} <= ops and engine.apu.core.rebinds == 0
    assert_same_frames(runs[True], runs[False])
    assert notes[True] == notes[False]
    assert probes[True] == probes[False]
    events = {(n["node"], n["event"]) for _, n in notes[True]}
    assert {("one", "started"), ("one", "completed"), ("one", "cancelled"), ("held", "started")} <= events
    sounds = [k for k, f in enumerate(runs[True]) if any(e["kind"] == "sound" for e in f[-2])]
    assert len(sounds) >= 3  # the ramp's event, on its plays and its loops
    yaw = np.array([f[0][desk.dof("head_yaw").channels.start] for f in runs[True]])
    assert np.ptp(yaw) > 0.1  # the clips moved the robot: the comparison covered motion


def test_a_probe_reads_a_playing_clips_outputs_as_they_are_now(monkeypatch, desk):
    """Nothing in the interactive program reads the gesture player's `weight`, `playing` or `time`: the
    kernel does not work them out on a steady tick, and a probe (telemetry) gets them brought up to date."""
    session = session_for(monkeypatch, desk, program("interactive"), True)
    engine = session.engine
    engine.apu.cook.every = 10**9
    gesture = engine.apu.block("gesture")
    session.execute({"type": "play_clip", "clip": "nod", "layer": "gesture"})
    seen = []
    for _ in range(20):
        engine.tick()
        st = gesture.state
        seen.append(
            engine.apu.signal_values([("gesture", "time"), ("gesture", "weight"), ("gesture", "playing")])
        )
        assert seen[-1] == [st.pos, smooth_step(st.env), True]
    assert len({time for time, _, _ in seen}) == 20  # it moved on every tick
