"""Timers the compiled core steps in the kernel: a weight shift's timing (its draws through a `trap`,
backend/engine/core/idle_ops.py), an LED's phase and a gaze's arc dip. They agree with the blocks' own
ticks frame for frame, with and without those ticks in between."""

from __future__ import annotations

from typing import Any

import pytest
from test_compiled_core import assert_same_frames, frame_tuple, session_for

from backend.engine.core import vm
from backend.engine.embodiment import load_embodiment
from backend.graph.builder import ProgramBuilder


@pytest.fixture(scope="module")
def robot():
    return load_embodiment("nutty_desk")


def shifting_program(min_interval: float, max_interval: float, duration: float) -> dict:
    b = ProgramBuilder("shifts")
    shift = b.node(
        "weight_shift",
        "shift",
        dofs=["body_yaw", "head_roll"],
        amplitude=0.1,
        min_interval=min_interval,
        max_interval=max_interval,
        shift_duration=duration,
    )
    led = b.node("led", "led", dof="eye_leds", mode="pulse", frequency=2.3, depth=0.7)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}, {"name": "b", "mode": "override"}])
    b.connect(shift, mix, "out", "a").connect(led, mix, "out", "b")
    b.chain(mix, b.output())
    return b.to_dict()


@pytest.mark.parametrize("every", [7, 10**9])
def test_weight_shifts_drawn_through_traps_agree(monkeypatch, robot, every):
    prog = shifting_program(0.5, 0.7, 0.3)
    runs, traps = {}, []
    for core in (True, False):
        session = session_for(monkeypatch, robot, prog, core)
        session.engine.apu.cook.every = every
        if core:
            (op,) = [op for op in session.engine.apu.core.ops if op.code == vm.OFFSET]
            own = op.trap
            op.trap = lambda dt, results, own=own: traps.append(dt) or own(dt, results)  # type: ignore[method-assign]  # a probe
        frames = []
        for k in range(300):
            if k == 150:
                session.update_params("shift", {"shift_duration": 0.5, "amplitude": 0.05})
            frames.append(frame_tuple(session.engine.tick()))
        runs[core] = frames
    assert_same_frames(runs[True], runs[False])
    assert len(traps) >= 2  # 3 s, a shift every 0.5-0.7 s (some drawn in the blocks' own ticks)
    channel = robot.dof("body_yaw").channels.start
    positions = [f[0][channel] for f in runs[True]]
    assert max(positions) - min(positions) > 0.01  # the shifts moved the body: the comparison covered them


def test_a_trap_stops_the_kernel_before_its_op_changes_anything(monkeypatch, robot):
    session = session_for(monkeypatch, robot, shifting_program(0.5, 0.5, 0.3), True)
    engine = session.engine
    engine.apu.cook.every = 10**9
    shift = engine.apu.block("shift")
    engine.run_ticks(3)
    seen = []
    (op,) = [op for op in engine.apu.core.ops if op.code == vm.OFFSET]
    own = op.trap

    def trap(dt, results):  # the state is as the last tick left it: the kernel stopped before stepping it
        seen.append((shift.state.until_next, shift.state.elapsed))
        return own(dt, results)

    op.trap = trap  # type: ignore[method-assign]  # a probe
    before = shift.state.until_next
    while not seen:
        engine.tick()
    assert seen[0][0] <= engine.dt + 1e-12 and seen[0][0] > 0.0
    assert 0.5 - 1e-9 <= shift.state.until_next <= 0.5 + 1e-9 and shift.state.elapsed == engine.dt
    assert before > seen[0][0]


def blinking_program() -> dict:
    b = ProgramBuilder("blinks")
    gaze = b.expose("gaze", "vec3", default=[1.0, 0.0, 0.3])
    hold = b.expose("hold", "bool", default=False)
    blink = b.node(
        "blink",
        "blink",
        dofs=["blink"],
        min_interval=0.3,
        mean_interval=0.5,
        max_interval=0.9,
        double_blink_probability=0.8,
        double_blink_gap=0.2,
    )
    b.connect(gaze, blink, "value", "gaze").connect(hold, blink, "value", "hold")
    lids = b.node("motion_filter", "lids", dofs=["blink"], preset="D")
    b.chain(blink, lids)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}])
    b.connect(lids, mix, "out", "a")
    b.chain(mix, b.output())
    return b.to_dict()


BLINK_SCRIPT: dict[int, Any] = {
    40: {"type": "set_input", "name": "gaze", "value": [0.2, 1.0, 0.3]},  # a gaze shift
    41: {"type": "set_input", "name": "gaze", "value": [0.2, 1.0, 0.3]},  # the same again: no shift
    170: "blink",  # the block's `blink` command: a blink now
    230: {"type": "set_input", "name": "gaze", "value": [1.0, -0.5, 0.0]},
}
# held expressions on and off, often: some cancel a pending second blink
BLINK_SCRIPT |= {k: {"type": "set_input", "name": "hold", "value": k % 2 == 0} for k in range(60, 160, 7)}


@pytest.mark.parametrize("every", [7, 10**9])
def test_blinks_agree_through_shifts_holds_commands_and_edits(monkeypatch, robot, every):
    runs, blinking, traps = {}, {}, []
    for core in (True, False):
        session = session_for(monkeypatch, robot, blinking_program(), core)
        session.engine.apu.cook.every = every
        if core:
            assert "blink" in {op.block.node_id for op in session.engine.apu.core.ops}
            (op,) = [op for op in session.engine.apu.core.ops if op.code == vm.BLINK]
            own = op.trap
            op.trap = lambda dt, results, own=own: traps.append(dt) or own(dt, results)  # type: ignore[method-assign]  # a probe
        frames, flags = [], []
        for k in range(300):
            command = BLINK_SCRIPT.get(k)
            if command == "blink":
                session.engine.apu.block("blink").handle("blink", {})
            elif command is not None:
                session.execute(command)
            if k == 200:
                session.update_params("blink", {"close_time": 0.05, "open_time": 0.1})
            frames.append(frame_tuple(session.engine.tick()))
            flags.append(session.engine.apu.signal_value("blink", "blinking"))
        runs[core], blinking[core] = frames, flags
    assert_same_frames(runs[True], runs[False])
    assert blinking[True] == blinking[False]
    assert blinking[True].count(True) > 20 and len(traps) >= 3  # it blinked, in the kernel too
