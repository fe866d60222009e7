"""Live hot swap: programs replaced 100 times while the engine's clock ticks.

Blocks whose id and type survive a swap keep their state, so their output continues without a
jump; the clock keeps ticking; invalid programs are rejected and change nothing; a parameter-only
change (`update_params`) rebuilds nothing.
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

from backend.engine.runtime import Sink
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession, SessionError

RATE = 200.0
AMP, FREQ = 0.2, 0.5
# The largest change of AMP*sin(phi) in one tick; a persisting sine never moves faster than this.
MAX_STEP = AMP * 2 * math.pi * FREQ / RATE


def variant(k: int) -> dict:
    """Program k of the swap sequence.

    Persisting in every variant: rest, breath (same params: its head_pitch output must be continuous),
    mixer (layers change), limit, output. Even k add an ear wiggle whose amplitude changes; odd k
    add a head-yaw look pose instead, and a gain node that comes and goes."""
    b = ProgramBuilder(f"variant {k}")
    rest = b.node("rest_pose", "rest", ui={"x": 0, "y": 0})
    breath = b.node("sine", "breath", dofs=["head_pitch"], amplitude=AMP, frequency=FREQ)
    layers = [{"name": "base"}, {"name": "idle", "mode": "additive", "mask": ["head_pitch"]}]
    links = [(rest, "base"), (breath, "idle")]
    if k % 2 == 0:
        wiggle = b.node(
            "sine", "wiggle", dofs=["ear_*"], amplitude=0.05 + 0.01 * (k % 10), frequency=1.0 + k % 3
        )
        layers.append(
            {"name": "ears", "mode": "additive", "mask": ["ear_*"], "weight": 0.5 + 0.05 * (k % 10)}
        )
        links.append((wiggle, "ears"))
    else:
        look = b.node("pose", "look", values={"head_yaw": 0.02 * (k % 5)})
        if k % 4 == 1:
            gain = b.node("gain_offset", "gain", dofs=["head_yaw"], gain=1.0 + 0.1 * (k % 7))
            b.chain(look, gain)
            look = gain
        layers.append({"name": "look", "mask": ["head_yaw"], "fade": 0.1})
        links.append((look, "look"))
    mix = b.node("layer_mixer", "mixer", layers=layers)
    for src, layer in links:
        b.connect(src, mix, "out", layer)
    limit = b.node("safety_limiter", "limit", velocity_scale=1.0)
    b.chain(mix, limit, b.output())
    return b.to_dict()


def broken(k: int) -> dict:
    doc = variant(k)
    doc["nodes"][1]["params"]["dofs"] = ["head_pich"]  # unknown_dof
    doc["edges"].append({"from": {"node": "ghost", "port": "out"}, "to": {"node": "limit", "port": "in"}})
    return doc


def wait_for_ticks(engine, n: int, timeout: float = 30.0) -> None:
    """Poll until the running clock has ticked `n` more times (the timeout only bounds a hang)."""
    target = engine.ticks + n
    deadline = time.monotonic() + timeout
    while engine.ticks < target:
        assert time.monotonic() < deadline, "the clock stopped ticking"
        time.sleep(0.002)


def jumps(values: np.ndarray, limit: float) -> np.ndarray:
    """Indices where consecutive samples differ by more than `limit` (with a little slack)."""
    return np.flatnonzero(np.abs(np.diff(values)) > limit * 1.05 + 1e-9)


def test_hundred_swaps_into_a_ticking_engine(desk):
    session = EngineSession.create(desk, rate=RATE, program=variant(0))
    engine = session.engine
    col = desk.dof("head_pitch").channels.start
    frames: list[tuple[int, float]] = []
    lock = threading.Lock()

    def record(frame):  # the program's own output (the safety net eases the sine in from rest)
        with lock:
            frames.append((frame.seq, float(frame.program[col])))

    sink = engine.add_sink(Sink("recorder", record, max_queue=1_000_000))
    rejected = 0
    engine.start()
    try:
        for k in range(1, 101):
            if k % 10 == 5:
                apu, swaps, program = engine.apu, engine.swaps, session.program
                with pytest.raises(SessionError) as exc:
                    session.load_program(broken(k))
                assert {e.code for e in exc.value.report.errors} == {"unknown_dof", "unknown_node"}
                assert engine.apu is apu and engine.swaps == swaps and session.program is program
                rejected += 1
            _, kept = session.load_program(variant(k))
            assert {"rest", "breath", "mixer", "limit", "output"} <= set(kept)
            # Nodes present in both variants keep state; look/wiggle alternate so they never persist.
            assert ("wiggle" in kept) is False and ("look" in kept) is False
            assert session.program.name == f"variant {k}"
            assert engine.apu.source is session.program
            wait_for_ticks(engine, 2)  # the new program runs a while before the next swap
        ticks_during = engine.ticks
    finally:
        engine.stop()
        engine.remove_sink(sink)

    assert engine.swaps == 101 and rejected == 10
    # Every frame reached the recorder, in order.
    assert sink.dropped == 0
    seqs = np.array([s for s, _ in frames])
    assert len(seqs) > 100 and np.all(np.diff(seqs) == 1)
    # The persisting sine never jumped: its output moved at most its own per-tick maximum.
    head_pitch = np.array([v for _, v in frames])
    assert not len(jumps(head_pitch, MAX_STEP)), f"jumps at frames {jumps(head_pitch, MAX_STEP)[:10]}"
    assert np.ptp(head_pitch) > AMP  # ... and it really moved (more than half its swing)
    # The clock ticked through every swap (its timing under load is benchmarks/bench_clock.py's).
    assert ticks_during >= 200 and len(seqs) >= ticks_during


def test_the_continuity_check_catches_a_reset_phase(desk):
    """Control: the same check flags the jump when the sine does not persist (renamed id)."""
    session = EngineSession.create(desk, rate=RATE, program=variant(0))
    col = desk.dof("head_pitch").channels.start
    values = [f.position[col] for f in session.run_headless(int(RATE / (4 * FREQ)))]  # a quarter period
    doc = variant(1)
    for n in doc["nodes"]:
        if n["id"] == "breath":
            n["id"] = "breath_2"
    for e in doc["edges"]:
        for end in (e["from"], e["to"]):
            if end["node"] == "breath":
                end["node"] = "breath_2"
    _, kept = session.load_program(doc)
    assert "breath_2" not in kept
    values += [f.position[col] for f in session.run_headless(20)]
    assert len(jumps(np.array(values), MAX_STEP)) > 0


def test_update_params_rebuilds_nothing(desk):
    session = EngineSession.create(desk, rate=RATE, program=variant(0))
    engine = session.engine
    col = desk.dof("head_pitch").channels.start
    # The program's own frames: its sine starts at full speed from rest, which the safety net smooths.
    before = [f.program[col] for f in session.run_headless(30)]
    apu = engine.apu
    blocks = {s.node_id: s.block for s in apu.steps}
    breath = apu.block("breath")
    phi = breath.state.phi
    engine.start()
    try:
        params = session.update_params("breath", {"frequency": FREQ * 1.2})
        wait_for_ticks(engine, 5)
    finally:
        engine.stop()
    assert params["frequency"] == pytest.approx(FREQ * 1.2) and params["amplitude"] == AMP
    assert engine.apu is apu and engine.swaps == 1
    assert {s.node_id: s.block for s in engine.apu.steps} == blocks
    assert all(engine.apu.block(n) is b for n, b in blocks.items())
    assert breath.params.frequency == pytest.approx(FREQ * 1.2)
    assert breath.state.phi != phi  # the phase went on from where it was, it was not reset
    # The running program's document follows the change.
    assert session.program.node("breath").params["frequency"] == pytest.approx(FREQ * 1.2)
    last = engine.last_frame.program[col]
    after = [f.program[col] for f in session.run_headless(30)]
    assert not len(jumps(np.array([last, *after]), MAX_STEP * 1.2))
    assert not len(jumps(np.array(before), MAX_STEP))


def test_update_params_rejects_bad_values_and_changes_nothing(desk):
    session = EngineSession.create(desk, rate=RATE, program=variant(0))
    breath = session.engine.apu.block("breath")
    params = breath.params
    for bad, code in [
        ({"amplitude": 99}, "invalid_param"),
        ({"amplitude_x": 1}, "unknown_param"),
        ({"dofs": ["head_pich"]}, None),
    ]:
        with pytest.raises(SessionError) as exc:
            session.update_params("breath", bad)
        if code:
            assert exc.value.code == code
        assert breath.params is params
    assert session.program.node("breath").params["amplitude"] == AMP


def test_headless_swaps_apply_at_once(desk):
    """Without a running clock a swap is applied before load_program returns (no tick needed)."""
    session = EngineSession.create(desk, rate=RATE, program=variant(0))
    for k in range(1, 21):
        session.load_program(variant(k))
        assert session.engine.apu.source is session.program and session.program.name == f"variant {k}"
    assert session.engine.swaps == 21
