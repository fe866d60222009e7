"""The engine's compiled tail (backend/engine/frame_tail.py) delivers what the Python path delivers —
the safety net's channel stage, the joints composed, the joint stage with its carry-back, and the
frame's derivatives — bit for bit, on the three robots with symbolic DoFs, on streams that make the
net correct, with the two paths taking turns over one net (a swap or an override hands a tick to the
Python path) and with resets between."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_joint_safety import ROBOTS, SEGMENT, robot, stream

from backend.engine.frame_tail import TAIL, FrameTail
from backend.engine.safety import SafetyNet


@pytest.fixture(scope="module", autouse=True)
def loaded_tail():
    assert TAIL.wait(120)  # loaded (or compiled, on a fresh clone) on its own thread


class Reference:
    """The Python path: `SafetyNet.step`, then the finite differences (as the engine writes them)."""

    def __init__(self, net: SafetyNet):
        self.net = net

    def tick(self, x: np.ndarray, last: tuple, dt: float, seq: int) -> tuple:
        pos = self.net.step(x)
        vel = (pos - last[0]) / dt if seq else np.zeros_like(pos)
        acc = (vel - last[1]) / dt if seq > 1 else np.zeros_like(pos)
        jerk = (acc - last[2]) / dt if seq > 2 else np.zeros_like(pos)
        return pos, vel, acc, jerk


def tick(tail: FrameTail, x: np.ndarray, last: tuple, dt: float, seq: int, python: bool) -> tuple:
    """One tick of the engine's tail: the kernel, or (`python`) the path a swap or an override takes;
    (position, velocity, acceleration, jerk)."""
    requested = (x.copy(), x.copy()) if python else None
    program, target, pos, vel, acc, jerk, stage1 = tail.run(x, x, last, dt, seq, requested)
    assert np.array_equal(program, x) and np.array_equal(target, x) and np.array_equal(stage1, x)
    return pos, vel, acc, jerk


def snapshot(net: SafetyNet, rows: tuple) -> tuple:
    """Everything a tick leaves that a reader sees: the frame's arrays, the joints, the marks, counts."""
    return (
        *(r.copy() for r in rows),
        net.joint_out.copy(),
        net.corrected.copy(),
        net.corrections.copy(),
        net.joint_corrected.copy(),
        net.joint_corrections.copy(),
        net.corrected_any,
        net.corrected_ticks,
    )


def assert_identical(a: tuple, b: tuple, k: int) -> None:
    names = ("position", "velocity", "acceleration", "jerk", "joints", "corrected", "corrections",
             "joint_corrected", "joint_corrections", "corrected_any", "corrected_ticks")  # fmt: skip
    for name, x, y in zip(names, a, b):
        assert np.array_equal(x, y), f"tick {k}: {name} differs: {x} vs {y}"


@pytest.mark.parametrize("name", list(ROBOTS))
@pytest.mark.parametrize("rate", [30.0, 100.0, 1000.0])
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(segments=st.lists(SEGMENT, min_size=1, max_size=6), turns=st.integers(0, 2**31 - 1))
def test_the_tail_and_the_python_path_agree_bit_for_bit(name, rate, segments, turns):
    emb, _ = robot(name)
    targets = stream(emb, segments, rate)
    dt = 1.0 / rate
    ref = Reference(SafetyNet(emb, rate))
    net = SafetyNet(emb, rate)
    tail = FrameTail(net)
    assert tail.fused
    pick = np.random.default_rng(turns)
    zeros = np.zeros(emb.n_channels)
    last_ref = last = (emb.rest.copy(), zeros, zeros)
    used = 0
    for k, x in enumerate(targets):
        seq = k
        if k and pick.random() < 0.02:  # a reset (the engine's: the position only, from the last output)
            ref.net.reset(last_ref[0])
            net.reset(last[0])
        want = ref.tick(x, last_ref, dt, seq)
        python = pick.random() < 0.2  # the Python path takes this tick on the same net (as on a swap)
        made = tail._made
        got = tick(tail, x, last, dt, seq, python)
        used += tail._made is not made
        assert_identical(snapshot(net, got), snapshot(ref.net, want), k)
        last_ref, last = want[:3], got[:3]
    assert used > 0


def test_a_correction_carried_back_from_a_joint_is_cleared_by_either_path():
    """nutty_desk's gaze drives the neck on top of its own channel: both at their velocity limits in the
    same direction exceed the neck's, so the joint stage corrects and carries back onto the neck's
    channel, whose mark the next tick clears, whichever path takes it."""
    emb, _ = robot("nutty_desk")
    rate, dt = 100.0, 0.01
    cont = emb.continuous_mask
    jump = np.where(cont, emb.max, emb.rest)  # every continuous channel to its top at once
    for second in ("tail", "python"):
        net = SafetyNet(emb, rate)
        tail = FrameTail(net)
        ref = Reference(SafetyNet(emb, rate))
        zeros = np.zeros(emb.n_channels)
        last = last_ref = (emb.rest.copy(), zeros, zeros)
        carried_seen = False
        for k in range(120):
            x = jump if k < 60 else emb.rest
            want = ref.tick(x, last_ref, dt, k)
            got = tick(tail, x, last, dt, k, python=second == "python" and bool(k % 2))
            carried_seen |= bool(net.carried_n[0])
            assert_identical(snapshot(net, got), snapshot(ref.net, want), k)
            last_ref, last = want[:3], got[:3]
        assert carried_seen, "the stream never made the joint stage carry a correction back"
        assert net.joint_corrections.any() and net.corrections.any()


def test_the_tail_checks_the_frames_it_reads():
    emb, _ = robot("nutty_desk")
    tail = FrameTail(SafetyNet(emb, 100.0))
    good = emb.rest.copy()
    assert tail.takes(good, good)
    assert not tail.takes(good[:-1], good)  # too short
    assert not tail.takes(good, np.repeat(good, 2)[::2])  # strided
    assert not tail.takes(good.astype(np.float32), good)
    assert not tail.takes(good.tolist(), good)  # type: ignore[arg-type]  # a list, as a faulty block might send
