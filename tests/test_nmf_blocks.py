"""The NMF as blocks: the chain operator and the stage-2 post-processor on the default robot."""

from __future__ import annotations

import numpy as np
import pytest

from backend.engine.trajectory import analyze
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession


def stepped_program(stage2: bool, **filter_params):
    b = ProgramBuilder("stepped")
    # a square wave on the head: the worst case for a motor
    src = b.node("sine", "steps", dofs=["head_yaw", "neck_pitch"], amplitude=0.3, frequency=0.5)
    sharp = b.node("gain_offset", "sharpen", gain=10.0)  # swings far beyond the joints' range
    if stage2:
        f = b.node("nmf_stage2", "nmf", **filter_params)
        b.chain(src, sharp, f, b.output())
    else:
        f = b.node("motion_filter", "nmf", dofs=["head_*", "neck_pitch"], **filter_params)
        b.chain(src, sharp, f, b.output())
    return b.build()


@pytest.mark.parametrize("stage2", [True, False])
def test_filtered_output_respects_the_robots_limits(desk, stage2):
    session = EngineSession.create(desk, rate=100, program=stepped_program(stage2))
    frames = list(session.run_headless(600))
    pos = np.array([f.position for f in frames])
    for name in ("head_yaw", "neck_pitch"):
        i = desk.channel_index[name]
        d = desk.dof(name)
        res = analyze(pos[:, i], 100, d.velocity, d.acceleration, d.jerk * 1.01, d.min, d.max)
        assert res.ok, (name, res.summary)
        assert np.ptp(pos[200:, i]) > 0.2  # it still moves a lot


def test_stage2_is_level3_and_exposes_the_ghost(desk):
    session = EngineSession.create(desk, rate=100, program=stepped_program(True))
    assert session.engine.apu.level == 3
    frames = list(session.run_headless(150))
    i = desk.channel_index["head_yaw"]
    ghost = np.array([f.stage1[i] for f in frames])
    final = np.array([f.position[i] for f in frames])
    assert np.abs(ghost - final).max() > 0.1  # the ghost (stage 1) leads the filtered robot


def test_slow_preset_is_slower_and_sigma_signal_changes_character(desk):
    peaks = {}
    for p in ("A", "D"):
        session = EngineSession.create(desk, rate=100, program=stepped_program(True, preset=p))
        pos = np.array([f.position[desk.channel_index["head_yaw"]] for f in session.run_headless(400)])
        peaks[p] = np.abs(np.diff(pos)).max()
    assert peaks["A"] < peaks["D"]


def test_live_param_change_keeps_filter_state(desk):
    session = EngineSession.create(desk, rate=100, program=stepped_program(True))
    list(session.run_headless(120))
    block = session.engine.apu.block("nmf")
    before = block.filter.position.copy()
    session.update_params("nmf", {"preset": "E", "limit_scale": 0.5})
    assert session.engine.apu.block("nmf") is block
    np.testing.assert_array_equal(block.filter.position, before)  # no jump, no reset
    assert block.filter.params()["sigma"][0] == pytest.approx(0.95)


def test_limit_overrides_bound_the_output_and_keep_state(desk):
    session = EngineSession.create(desk, rate=100, program=stepped_program(True))
    list(session.run_headless(100))
    block = session.engine.apu.block("nmf")
    before = block.filter.position.copy()
    session.update_params("nmf", {"preset": "D", "vel_limit": 0.2, "acc_limit": 2.0, "jerk_limit": 50.0})
    assert session.engine.apu.block("nmf") is block
    np.testing.assert_array_equal(block.filter.position, before)  # no reset
    assert block.filter.params()["vel_limit"][0] == pytest.approx(0.4)  # tanh: V = 2 x the output bound
    frames = list(session.run_headless(400))
    i = desk.channel_index["head_yaw"]
    # The filter's own output (the program's frame); the engine's safety net eases the sudden slow-down.
    pos = np.array([f.program[i] for f in frames])
    assert np.abs(np.diff(pos)).max() * 100 <= 0.2 + 1e-9  # the output stays below the new bound


def test_stage2_filters_every_continuous_channel_with_the_robots_limits(desk):
    from backend.engine.embodiment import ChannelKind

    session = EngineSession.create(desk, rate=100, program=stepped_program(True))
    list(session.run_headless(1))
    block = session.engine.apu.block("nmf")
    sel = desk.channel_kind != ChannelKind.enum
    np.testing.assert_array_equal(block.idx, np.flatnonzero(sel))
    np.testing.assert_allclose(block.filter.params()["acc_limit"], desk.acc_limit[sel])
    np.testing.assert_allclose(block.filter.params()["vel_limit"], 2 * desk.vel_limit[sel])
