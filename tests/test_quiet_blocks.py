"""Quiet blocks (backend/engine/blocks/quiet.py): the compiled core skips an idle voice, sound player,
face or posture while nothing it reads changed, and ticks it again on a command, an edit or a reset.
The clip player runs in the kernel (backend/engine/core/clip_ops.py): its Python tick runs only at a
clip's start, events and end. That the skips change no frame is checked with every other path in
tests/test_compiled_core.py (the core against the blocks' own ticks under the scripted AI)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from backend.engine.blocks.quiet import QuietWhenIdle
from backend.engine.core.program import CORE_ENV, KERNEL
from backend.engine.embodiment import load_embodiment
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

PROGRAM = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs" / "interactive.json"
QUIET = ("voice", "sfx", "face", "posture", "gesture", "puppet", "look_at_weight")
#: Quiet blocks the core runs in the kernel instead (backend/engine/core/signal_ops.py, clip_ops.py): no
#: Python tick but the clip player's at a clip's start, events and end (its `trap`, counted here too).
IN_KERNEL = ("emotion", "breath_amplitude", "gesture")


@pytest.fixture
def counted(monkeypatch):
    """The interactive program on the core, with each quiet block's ticks counted."""
    monkeypatch.setenv(CORE_ENV, "1")
    assert KERNEL.wait(120)
    session = EngineSession.create(load_embodiment("nutty_desk"), program=json.loads(PROGRAM.read_text()))
    engine = session.engine
    engine.apu.cook.every = 10**9  # no timed tick: every tick is the core's
    counts: Counter[str] = Counter()
    for node in QUIET:
        block = engine.apu.block(node)
        assert isinstance(block, QuietWhenIdle)
        own = block.tick

        def tick(dt, inputs, own=own, node=node):
            counts[node] += 1
            return own(dt, inputs)

        block.tick = tick
    engine.run_ticks(30)
    assert engine.apu.core is not None and engine.apu.core.ready()
    assert set(IN_KERNEL) <= {op.block.node_id for op in engine.apu.core.ops}
    counts.clear()
    yield session, counts
    engine.close()


def test_idle_blocks_are_skipped_until_something_reaches_them(counted):
    session, counts = counted
    engine = session.engine
    engine.run_ticks(20)
    assert counts == Counter()  # all idle or settled: not one tick
    session.execute({"type": "say", "text": "hi"})
    engine.run_ticks(10)
    assert counts["voice"] == 10  # speaking: every tick
    session.execute({"type": "set_face", "expression": "smile"})
    engine.run_ticks(5)
    assert counts["face"] == 1  # the command's tick, then quiet again
    session.update_params("posture", {"duration": 2.0})
    engine.run_ticks(5)
    assert counts["posture"] == 1
    counts.clear()
    for node in ("face", "sfx", "gesture"):
        engine.apu.block(node).reset()  # a new state object (a hot swap's adoption likewise)
    engine.run_ticks(5)
    assert [counts[node] for node in ("face", "sfx", "gesture", "posture")] == [1, 1, 0, 0]
    counts.clear()
    before = engine.apu.signal_value("emotion", "valence")
    session.execute({"type": "set_emotion", "valence": 0.5, "arousal": 0.2})
    engine.run_ticks(5)
    # new inputs, then smoothing toward them every tick, in the kernel: no Python block woke for it (the
    # voice still says "hi")
    assert engine.apu.signal_value("emotion", "valence") != before and set(counts) <= {"voice"}


def test_a_clip_follows_a_speed_that_changes_every_tick_without_a_python_tick(counted):
    """The emotion's smoothing moves the gesture's wired speed every tick, in the kernel; a playing clip's
    steady ticks run there too: its Python tick runs at its end only (nod has no events), and the
    playhead moved by the emotion's speed each tick (that the frames agree with the blocks' own ticks:
    tests/test_compiled_core.py, tests/test_core_clips.py)."""
    session, counts = counted
    engine = session.engine
    gesture = engine.apu.block("gesture")
    session.execute({"type": "set_emotion", "valence": 0.6, "arousal": 0.9})
    engine.run_ticks(20)
    session.execute({"type": "play_clip", "clip": "nod", "layer": "gesture"})
    moved = []
    for _ in range(30):
        before = gesture.state.pos
        engine.tick()
        moved.append(gesture.state.pos - before)
    speeds = [engine.apu.signal_value("emotion", "speed")]
    assert counts["gesture"] == 0 and gesture.state.current is not None
    assert len(set(moved)) > 5 and abs(moved[-1] - speeds[0] * engine.dt) < 1e-12  # the speed moved
    for _ in range(600):  # the clip ends (Python: its notes), then its fade-out (Python: the clip is gone)
        engine.tick()
        if gesture.state.current is None:
            break
    assert gesture.state.current is None and counts["gesture"] == 2
    counts.clear()
    engine.run_ticks(10)
    assert counts["gesture"] == 0


def test_a_command_wakes_a_quiet_block():
    session = EngineSession.create(load_embodiment("nutty_desk"), program=json.loads(PROGRAM.read_text()))
    try:
        face = session.engine.apu.block("face")
        session.engine.run_ticks(2)
        assert face.quiet
        session.execute({"type": "set_face", "expression": "smile"})
        assert not face.quiet
    finally:
        session.engine.close()


def test_a_puppet_streamed_to_dropped_and_streamed_to_again_agrees_with_its_own_ticks(monkeypatch):
    """The puppet goes quiet once faded out; a `set` wakes it (the scripted AI streams no puppet, so
    this is its check of the core against the blocks' own ticks)."""
    runs = {}
    for core in (True, False):
        monkeypatch.setenv(CORE_ENV, "1" if core else "0")
        assert KERNEL.wait(120)
        session = EngineSession.create(load_embodiment("nutty_desk"), program=json.loads(PROGRAM.read_text()))
        frames = []
        for k in range(500):
            if k in (20, 21, 22, 300) or 320 <= k < 330:
                session.execute({"type": "puppet", "values": {"head_yaw": 0.2 + 0.01 * (k % 7)}})
            if k == 340:
                session.execute({"type": "puppet", "release": True})
            tick = session.engine.tick()
            # the look_at weight follows the puppet's weight as the puppet fades by itself (no command): a
            # quiet block asleep is woken by its source handing out a new value
            frames.append((tick.position.copy(), session.engine.apu.signal_value("look_at_weight", "value")))
        runs[core] = frames
        if core:
            assert session.engine.apu.block("puppet").quiet  # faded out after the release
        session.engine.close()
    diffs = [float(abs(a[0] - b[0]).max()) for a, b in zip(runs[True], runs[False])]
    assert max(diffs) <= 1e-9
    assert [w for _, w in runs[True]] == [w for _, w in runs[False]]
    assert len({w for _, w in runs[True]}) > 10  # it faded in and out
    yaw = load_embodiment("nutty_desk").dof("head_yaw").channels.start
    assert abs(runs[True][60][0][yaw] - runs[True][10][0][yaw]) > 0.05  # the stream moved the head


def test_a_sleeping_block_wakes_when_its_source_changes_by_itself(monkeypatch):
    """A sound player triggered by the voice's `speaking` sleeps while it holds; the speech ends by
    itself (no command), and the player must see that falling edge, or the next utterance's rising edge
    would play no sound."""
    b = ProgramBuilder("echo")
    voice = b.node("say", "voice")
    sfx = b.node("play_sound", "sfx", sound="beep")
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}, {"name": "b"}])
    b.connect(voice, sfx, "speaking", "trigger")
    b.connect(voice, mix, "out", "a").connect(sfx, mix, "out", "b").chain(mix, b.output())
    runs = {}
    for core in (True, False):
        monkeypatch.setenv(CORE_ENV, "1" if core else "0")
        assert KERNEL.wait(120)
        session = EngineSession.create(load_embodiment("nutty_desk"), program=b.to_dict())
        session.engine.apu.cook.every = 10**9
        kinds = []
        for k in range(600):
            if k in (5, 300):
                session.execute({"type": "say", "text": "hello there"})
            kinds.append([e.kind for e in session.engine.tick().events])
        runs[core] = kinds
        session.engine.close()
    assert runs[True] == runs[False]
    assert sum(kinds.count("sound") for kinds in runs[True]) == 2
