"""The APU levels, hot swaps keeping state, the steady clock, and sinks that never stall it."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from backend.engine.apu import LevelError
from backend.engine.runtime import Engine, Sink, WallClock
from backend.graph.builder import ProgramBuilder
from backend.graph.compiler import compile_or_raise
from backend.session import EngineSession


def level0():
    b = ProgramBuilder("l0")
    b.chain(b.node("sine", "wave", dofs=["head_yaw"], amplitude=0.3, frequency=1.0), b.output())
    return b


def level1():
    b = ProgramBuilder("l1")
    s = b.node("sine", "wave", dofs=["head_*"], amplitude=0.3, frequency=1.0)
    g = b.node("gain_offset", "gain", dofs=["head_yaw"], gain=2.0)
    b.chain(s, g, b.output())
    return b


def level2(weight=1.0):
    b = ProgramBuilder("l2")
    rest = b.node("rest_pose", "rest")
    s = b.node("sine", "wave", dofs=["head_yaw"], amplitude=0.3, frequency=1.0)
    ears = b.node("sine", "ears", dofs=["ear_*"], amplitude=0.2, frequency=2.0)
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[
            {"name": "base"},
            {"name": "idle", "mode": "additive"},
            {"name": "gesture", "mode": "override", "weight": weight, "mask": ["head_*"]},
        ],
    )
    b.connect(rest, mix, "out", "base").connect(ears, mix, "out", "idle").connect(s, mix, "out", "gesture")
    b.chain(mix, b.output())
    return b


def level3():
    b = level2()
    out = b.doc["edges"].pop()  # mix -> output
    lim = b.node("safety_limiter", "safety", velocity_scale=0.5)
    b.connect(out["from"]["node"], lim).connect(lim, "output")
    return b


@pytest.mark.parametrize("make, level", [(level0, 0), (level1, 1), (level2, 2), (level3, 3)])
def test_level_detection(desk, make, level):
    assert compile_or_raise(make().build(), desk).apu.level == level


def test_engine_refuses_programs_above_its_level(desk):
    eng = Engine(desk, rate=100, max_level=1)
    apu = compile_or_raise(level2().build(), desk).apu
    with pytest.raises(LevelError, match="level 2"):
        eng.load(apu)
    assert eng.apu is None


def test_level2_mixes_layers(desk):
    session = EngineSession.create(desk, rate=100, program=level2().build())
    frames = list(session.run_headless(100))
    yaw = desk.channel_index["head_yaw"]
    ear = desk.channel_index["ear_left"]
    pos = np.array([f.program for f in frames])  # the program's own frames (the safety net smooths its steps)
    assert np.ptp(pos[:, yaw]) == pytest.approx(0.6, abs=0.02)  # gesture layer overrides head_yaw
    assert np.ptp(pos[:, ear]) == pytest.approx(0.4, abs=0.02)  # additive idle on the ears
    np.testing.assert_allclose(pos[:, desk.channel_index["eye_leds.b"]], 1.0)  # base layer: rest colour


def test_layer_fade_out_and_in(desk):
    session = EngineSession.create(desk, rate=100, program=level2().build())
    list(session.run_headless(30))
    session.execute({"type": "set_layer", "layer": "gesture", "active": False, "fade": 0.5})
    mixer = session.engine.apu.block("mix")
    list(session.run_headless(25))
    assert mixer.state.fade_level[2] == pytest.approx(0.5, abs=0.03)
    list(session.run_headless(30))
    assert mixer.state.fade_level[2] == 0.0
    yaw = desk.channel_index["head_yaw"]
    assert session.engine.last_frame.program[yaw] == pytest.approx(0.0, abs=1e-9)
    list(session.run_headless(100))  # the safety net brings the robot there within its limits
    assert session.engine.last_frame.position[yaw] == pytest.approx(0.0, abs=1e-9)


def test_hot_swap_keeps_state_of_surviving_blocks(desk):
    session = EngineSession.create(desk, rate=100, program=level1().build())
    list(session.run_headless(37))
    phi_before = session.engine.apu.block("wave").state.phi
    doc = level1().to_dict()
    doc["nodes"][1]["params"]["gain"] = 1.5  # gain node changes, the sine keeps its id and type
    _, kept = session.load_program(doc)
    assert {"wave", "gain"} <= set(kept)
    session.engine.tick()
    assert session.engine.apu.block("wave").state.phi == pytest.approx(phi_before + 2 * np.pi * 0.01)


def test_swap_of_new_block_type_starts_fresh(desk):
    session = EngineSession.create(desk, rate=100, program=level1().build())
    list(session.run_headless(20))
    doc = level1().to_dict()
    doc["nodes"][0]["id"] = "wave2"
    doc["edges"][0]["from"]["node"] = "wave2"
    _, kept = session.load_program(doc)
    assert "wave2" not in kept
    assert session.engine.apu.block("wave2").state.phi == 0.0


def test_empty_program_outputs_rest_and_partial_frames_hold(desk):
    eng = Engine(desk, rate=50)
    frame = eng.tick()
    np.testing.assert_allclose(frame.position, desk.rest)
    b = ProgramBuilder("hold")
    b.chain(b.node("pose", "p", values={"head_yaw": 0.4}), b.output())
    eng.load(compile_or_raise(b.build(), desk).apu)
    frame = eng.tick()
    assert frame.program[desk.channel_index["head_yaw"]] == pytest.approx(0.4)
    assert frame.program[desk.channel_index["eyelid_left"]] == pytest.approx(0.15)  # untouched: rest
    frame = eng.run_ticks(150)[-1]  # the safety net takes the robot there within its limits
    assert frame.position[desk.channel_index["head_yaw"]] == pytest.approx(0.4)
    assert frame.position[desk.channel_index["eyelid_left"]] == pytest.approx(0.15)


def test_frame_derivatives_are_finite_differences(desk):
    session = EngineSession.create(desk, rate=100, program=level0().build())
    frames = list(session.run_headless(50))
    i = desk.channel_index["head_yaw"]
    p = np.array([f.position[i] for f in frames])
    v = np.array([f.velocity[i] for f in frames])
    np.testing.assert_allclose(v[1:], np.diff(p) * 100)
    assert frames[10].seq == 10 and frames[10].t == pytest.approx(0.1)


def test_faulty_block_never_kills_the_clock(desk):
    session = EngineSession.create(desk, rate=100, program=level0().build())
    block = session.engine.apu.block("wave")
    # a bug in a block (in `driven`, which its own tick and the compiled core's op both call)
    block.driven = lambda *args, **kw: 1 / 0
    notes = []
    session.on_note(notes.append)
    frames = list(session.run_headless(5))
    assert len(frames) == 5
    assert notes and notes[0]["event"] == "error" and "ZeroDivisionError" in notes[0]["message"]


def test_call_soon_applies_at_tick_boundary_from_other_threads(desk):
    eng = Engine(desk, rate=100)
    eng.start()
    try:
        results = []
        threads = [
            threading.Thread(target=lambda k=k: results.append(eng.call(lambda: k * 2))) for k in range(20)
        ]
        for t in threads:
            t.start()
        for t in threads:
            t.join(5)
        assert sorted(results) == [k * 2 for k in range(20)]
        fut = eng.call_soon(lambda: 1 / 0)
        with pytest.raises(ZeroDivisionError):
            fut.result(2)
        assert eng.running  # an error in a queued call never stops the clock
    finally:
        eng.close()


class SimulatedClock:
    """A clock for the engine's loop that never sleeps: each wait returns at its deadline at once
    (later by `late[k]` seconds on the k-th wait, a scheduler waking the thread late), and the loop
    ends itself after `ticks` waits. `wakes` lists the time of every wake-up."""

    def __init__(self, ticks: int, late: dict[int, float] | None = None):
        self.t = 0.0
        self.ticks = ticks
        self.late = late or {}
        self.wakes: list[float] = []
        self.done = threading.Event()

    def now(self) -> float:
        return self.t

    def wait_until(self, deadline: float, stop: threading.Event) -> bool:
        if len(self.wakes) == self.ticks or stop.is_set():
            self.done.set()
            return False
        self.t = max(self.t, deadline) + self.late.get(len(self.wakes), 0.0)
        self.wakes.append(self.t)
        return True


def run_clock(eng: Engine, clock: SimulatedClock) -> None:
    eng.start()
    assert clock.done.wait(60), "the simulated clock did not finish"
    eng.stop()


def test_clock_ticks_once_per_period(desk):
    clock = SimulatedClock(ticks=200)
    eng = Engine(desk, rate=200, clock=clock)
    eng.load(compile_or_raise(level3().build(), desk).apu)
    frames = []
    eng.add_sink(Sink("all", frames.append, max_queue=1000))
    run_clock(eng, clock)
    eng.close()
    stats = eng.stats()
    assert stats["ticks"] == 200 and stats["lost_ticks"] == 0 and stats["overruns"] == 0
    np.testing.assert_allclose(np.diff(clock.wakes), 0.005)  # one tick every 5 ms
    assert stats["period"]["p50_ms"] == pytest.approx(5.0) and stats["jitter"]["max_ms"] == pytest.approx(0.0)
    assert [f.seq for f in frames] == list(range(200)) and eng.t == pytest.approx(1.0)


def test_a_late_clock_stretches_time_and_counts_lost_ticks(desk):
    """Woken 3.5 periods late, the clock skips the ticks it missed (counted as lost) rather than
    bursting to catch up, and the program's time goes on one period per tick."""
    clock = SimulatedClock(ticks=100, late={50: 3.5 * 0.01})
    eng = Engine(desk, rate=100, clock=clock)
    eng.load(compile_or_raise(level2().build(), desk).apu)
    run_clock(eng, clock)
    stats = eng.stats()
    assert stats["ticks"] == 100 and stats["overruns"] == 1 and stats["lost_ticks"] == 2
    (overrun,) = stats["recent_overruns"]  # what /api/status says of it: a stalled wake, not a long tick
    assert overrun["late_ms"] == pytest.approx(35.0) and overrun["tick_ms"] == 0.0 and overrun["lost"] == 2
    assert abs(overrun["at"] - time.time()) < 60
    slots = np.delete(np.array(clock.wakes), 50) / 0.01
    np.testing.assert_allclose(slots, np.round(slots), atol=1e-6)  # every other tick on the 10 ms grid ...
    assert len(set(np.round(slots))) == 99  # ... one per slot: no burst to catch up
    assert clock.wakes[51] - clock.wakes[50] == pytest.approx(0.005)  # back on the grid at the next slot
    assert eng.t == pytest.approx(1.0) and eng.last_frame.seq == 99  # time stretched, nothing skipped


def test_slow_sink_does_not_stall_the_clock(desk):
    clock = SimulatedClock(ticks=200)
    eng = Engine(desk, rate=200, clock=clock)
    eng.load(compile_or_raise(level2().build(), desk).apu)
    release = threading.Event()
    slow = eng.add_sink(Sink("slow", lambda f: release.wait(60), max_queue=4))  # stuck until released
    fast_frames = []
    eng.add_sink(Sink("fast", fast_frames.append, max_queue=1000))
    run_clock(eng, clock)  # all 200 ticks ran while the slow sink sat on its first frame
    assert eng.flush_sinks()  # (every frame offered to both: the fast sink's queue holds them all)
    assert eng.ticks == 200 and slow.delivered == 0 and slow.dropped >= 200 - 4 - 1
    release.set()
    eng.close()
    assert slow.delivered + slow.dropped == 200 and slow.delivered <= 5
    assert [f.seq for f in fast_frames] == list(range(200))  # the fast sink got everything, in order


def test_wall_clock_waits_end_at_the_deadline_or_when_stopped():
    clock, stop = WallClock(), threading.Event()
    assert clock.wait_until(clock.now() - 1.0, stop) is True  # a deadline already past: at once
    stop.set()
    assert clock.wait_until(clock.now() + 3600.0, stop) is False  # stopped: no hour-long wait


def test_sink_decimation_and_errors(desk):
    eng = Engine(desk, rate=100)
    got = []
    eng.add_sink(Sink("every4", got.append, max_queue=100, decimate=4))
    bad = eng.add_sink(Sink("bad", lambda f: 1 / 0, max_queue=100))
    eng.run_ticks(40)
    eng.close()
    assert [f.seq for f in got] == list(range(0, 40, 4))
    assert bad.errors == 40 and "ZeroDivisionError" in bad.last_error


def test_rate_is_validated(desk):
    with pytest.raises(ValueError, match="rate must be within"):
        Engine(desk, rate=5)
    with pytest.raises(ValueError, match="rate must be within"):
        Engine(desk, rate=5000)


def test_parameter_only_program_load_rebuilds_nothing(desk):
    session = EngineSession.create(desk, rate=100, program=level2().build())
    list(session.run_headless(10))
    apu = session.engine.apu
    blocks = [s.block for s in apu.steps]
    doc = level2(weight=0.5).to_dict()
    doc["nodes"][0]["ui"] = {"x": 999, "y": 1}  # editor data may change too
    _, kept = session.load_program(doc)
    assert session.engine.apu is apu
    assert [s.block for s in apu.steps] == blocks
    assert session.engine.apu.block("mix").weights[2] == 0.5
    assert set(kept) == {s.node_id for s in apu.steps}
    assert session.program.nodes[0].ui == {"x": 999, "y": 1}
    # a structural change (a new node) does swap in a new APU
    b = level2()
    b.node("sine", "extra", dofs=["ear_left"])
    session.load_program(b.build())
    assert session.engine.apu is not apu


def test_empty_selector_list_selects_nothing(desk):
    from backend.engine.selectors import channel_mask

    assert not channel_mask(desk, []).any()
    assert channel_mask(desk, ["!head_*"]).sum() == desk.n_channels - 3


def test_clock_priority_restores_the_switch_interval_when_the_last_clock_stops():
    import sys
    import threading

    from backend.engine.gil import ClockPriority

    before = sys.getswitchinterval()
    a, b = ClockPriority(interval=0.0004, nice_boost=0), ClockPriority(interval=0.0004, nice_boost=0)
    a.apply()
    b.apply()
    assert sys.getswitchinterval() == pytest.approx(0.0004, abs=2e-6)  # kept in whole µs
    a.restore()
    assert sys.getswitchinterval() == pytest.approx(0.0004, abs=2e-6)  # kept in whole µs  # b still runs
    b.restore()
    b.restore()  # twice is harmless
    assert sys.getswitchinterval() == before
    raised = ClockPriority(interval=0.0004, nice_boost=1)
    worker = threading.Thread(target=raised.apply)
    worker.start()
    worker.join()
    raised.restore()
    assert raised.nice is None or raised.nice <= 0  # raised where the OS permits it, never lowered


def test_clock_thread_runs_real_time_where_permitted_and_its_children_do_not(monkeypatch):
    """The clock thread takes SCHED_FIFO where the OS allows it (here: root on Linux, or nothing);
    threads it starts get the normal policy; the switch `NUTTY_CLOCK_REALTIME=0` keeps it off."""
    import os
    import sys
    import threading

    from backend.engine.gil import REALTIME_ENV, ClockPriority

    seen: dict[str, int] = {}

    def clock_thread(priority: ClockPriority) -> None:
        priority.apply()
        seen["clock"] = os.sched_getscheduler(0) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
        child = threading.Thread(target=lambda: seen.__setitem__("child", os.sched_getscheduler(0)))
        child.start()
        child.join()
        priority.restore()
        seen["after"] = os.sched_getscheduler(0)

    if not sys.platform.startswith("linux"):
        pytest.skip("per-thread scheduling policies are Linux's")
    rt = ClockPriority(nice_boost=0)
    worker = threading.Thread(target=clock_thread, args=(rt,))
    worker.start()
    worker.join()
    if rt.realtime_priority and seen["clock"] == os.SCHED_FIFO:  # permitted here
        assert seen["child"] == os.SCHED_OTHER and seen["after"] == os.SCHED_OTHER
    else:
        assert seen["clock"] == os.SCHED_OTHER  # not permitted: unchanged, and no error
    monkeypatch.setenv(REALTIME_ENV, "0")
    off = ClockPriority(nice_boost=0)
    worker = threading.Thread(target=clock_thread, args=(off,))
    worker.start()
    worker.join()
    assert off.realtime is None and seen["clock"] == os.SCHED_OTHER


def test_the_collector_waits_for_imports_beside_a_clock_and_never_walks_what_they_made():
    """collector_paused: no cyclic collection inside it (however much is allocated), the collector on
    again after it, and what it made frozen out of later collections' walk."""
    import gc

    from backend.engine.gil import collector_paused

    collections = []

    def seen(phase: str, info: dict) -> None:
        if phase == "start":
            collections.append(info["generation"])

    gc.callbacks.append(seen)
    frozen = gc.get_freeze_count()
    try:
        with collector_paused():
            assert not gc.isenabled()
            made = [[i, [i]] for i in range(50_000)]  # far past the young generation's threshold
        assert collections == [] and gc.isenabled()
        assert gc.get_freeze_count() >= frozen + len(made)
        assert not any(o is made[0] for o in gc.get_objects(generation=2))  # frozen: in no generation
    finally:
        gc.callbacks.remove(seen)
        gc.unfreeze()  # the rest of the test session collects as usual
