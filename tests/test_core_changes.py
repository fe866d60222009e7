"""What the compiled core learns at edit and command time (backend/engine/blocks/block_state.py): every
replaced parameters or state object and every command a block handles is counted, the core looks at its
ops only when the count moved, and what a command sets (a gaze's look_at in progress) is then in the
kernel, which ends the look_at and publishes `on_target` in the same ticks as the blocks' own ticks."""

from __future__ import annotations

import numpy as np
import pytest
from test_compiled_core import assert_same_frames, frame_tuple, program, session_for

from backend.engine.blocks.base import BlockCommandError
from backend.engine.blocks.block_state import CHANGES, copy_state


@pytest.fixture(scope="module")
def robot():
    from backend.engine.embodiment import load_embodiment  # lazy: the fixture's robot only

    return load_embodiment("nutty_desk")


def test_replacing_params_or_state_and_handling_commands_count_and_reading_does_not(monkeypatch, robot):
    session = session_for(monkeypatch, robot, program("interactive"), True)
    led, gaze = session.engine.apu.block("eye_leds"), session.engine.apu.block("gaze")
    before = CHANGES[0]
    for _ in range(3):  # reads: never counted
        _ = led.params, led.state, gaze.state.x
    assert CHANGES[0] == before
    led.state = copy_state(led.state)
    led.params = led.params.model_copy()
    led.handle("set_led", {"colour": [0.1, 0.2, 0.3]})
    with pytest.raises(BlockCommandError):  # a command that fails counts too: it may have changed something
        gaze.handle("no such command", {})
    assert CHANGES[0] == before + 4
    assert type(led).__dict__["handle"].__wrapped__  # each class's own handle is wrapped, once


def test_a_state_replaced_between_ticks_is_bound_at_the_next_core_tick(monkeypatch, robot):
    session = session_for(monkeypatch, robot, program("breathe-anything"), True)
    engine = session.engine
    engine.apu.cook.every = 10**9  # core ticks only: no timed tick to catch it instead
    engine.run_ticks(5)
    limiter = engine.apu.block("safety")
    limiter.state = copy_state(limiter.state)  # announced by the assignment alone
    engine.tick()
    (op,) = [op for op in engine.apu.core.ops if op.block is limiter]
    assert engine.apu.core.listed(op, 1)[0] is limiter.state.last
    assert np.array_equal(engine.apu.signal_value("safety", "out").values, limiter.state.last)
    assert engine.apu.core.rebinds == 0


# A look_at that reaches its target, one replaced before it does, one beyond the gaze's range (it ends when
# the gaze stands still at a limit), one stopped (cancelled), one whose command was cancelled (it ends
# without a note), and one that begins while the gaze is on target. (Without the hub, a look_at's
# command id is "None".)
LOOKS: dict[int, dict | tuple[str, dict]] = {
    5: {"type": "set_gaze", "target": [0.6, 0.3, 0.4]},
    90: {"type": "set_gaze", "target": [0.4, -0.5, 0.2]},
    95: {"type": "set_gaze", "target": [0.1, 0.0, 2.0]},
    460: {"type": "set_gaze", "target": [0.5, 0.0, 0.35]},
    463: ("stop", {}),
    530: {"type": "set_gaze", "target": [0.2, 0.5, 0.3]},
    532: ("unwatch", {"command_id": "None"}),
    620: {"type": "set_gaze", "target": [0.2, 0.5, 0.3]},
}


@pytest.mark.parametrize("every", [7, 10**9])
def test_look_ats_end_and_on_target_flips_in_the_same_ticks_on_both_paths(monkeypatch, robot, every):
    runs, notes, on_target = {}, {}, {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, program("interactive"), core)
        session.engine.apu.cook.every = every  # the blocks' own ticks between the core's, or never
        engine = session.engine
        notes[core] = []
        session.on_note(
            lambda n, seen=notes[core], e=engine: seen.append((e.seq, n)) if n["node"] == "gaze" else None
        )
        gaze = engine.apu.block("gaze")
        frames, flags = [], []
        for k in range(700):
            look = LOOKS.get(k)
            if isinstance(look, tuple):
                engine.call(lambda look=look, gaze=gaze: gaze.handle(*look))
            elif look is not None:
                session.execute(look)
            frames.append(frame_tuple(engine.tick()))
            flags.append(engine.apu.signal_value("gaze", "on_target"))
        runs[core], on_target[core] = frames, flags
    assert_same_frames(runs[True], runs[False])
    assert on_target[True] == on_target[False]
    assert True in on_target[True] and False in on_target[True]
    assert notes[True] == notes[False]
    ended = [(n["event"], n.get("reached")) for _, n in notes[True] if n["event"] != "started"]
    assert ("completed", True) in ended and ("completed", False) in ended and ("cancelled", False) in ended
