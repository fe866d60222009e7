"""The compiled program core (backend/engine/core) computes what the blocks' own ticks compute: frame
for frame, bit for bit (within 1e-9), on every shipped program under the scripted AI, through live
parameter edits, mixer commands, hot swaps and resets, and on random programs (hypothesis). Its
arrays are the blocks' own, a replaced one is caught, and its hot path allocates nothing that grows.
Speed is benchmarks/bench_engine.py's business, not these tests'."""

from __future__ import annotations

import json
import threading
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import scripted_ai
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from backend.engine.core.program import CORE_ENV, KERNEL, Arena, Import
from backend.engine.embodiment import load_embodiment
from backend.engine.frame_tail import TAIL
from backend.engine.frames import PartialFrame, SteadyFrame
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

PROGRAMS = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs"
TOLERANCE = 1e-9


def program(name: str) -> dict:
    return json.loads((PROGRAMS / f"{name}.json").read_text())


@pytest.fixture(scope="module")
def robot():
    return load_embodiment("nutty_desk")


def session_for(monkeypatch, robot, prog: dict, core: bool) -> EngineSession:
    monkeypatch.setenv(CORE_ENV, "1" if core else "0")
    assert KERNEL.wait(120)  # loaded (or compiled, on a fresh clone) on its own thread
    assert TAIL.wait(120)  # the engine's compiled tail, likewise
    session = EngineSession.create(robot, program=prog)
    assert (session.engine.apu.core is not None) == core
    return session


#: A frame's arrays compared, with their order of finite difference (a position's error e becomes up to
#: 2e/dt, 4e/dt² and 8e/dt³ in its derivatives).
FIELDS = (("position", 0), ("stage1", 0), ("program", 0), ("joints", 0), ("velocity", 1),
          ("acceleration", 2), ("jerk", 3))  # fmt: skip


def frame_tuple(f) -> tuple:
    """A frame's channels, stage 1, program frame, the joints the motors get, the derivatives, the
    channels the net corrected, and its events (the core runs with the engine's compiled tail, the
    blocks with the Python path: `NUTTY_CORE=0` turns both off)."""
    return (
        *(getattr(f, name).copy() for name, _ in FIELDS),
        None if f.corrected is None else f.corrected.copy(),
        [e.to_dict() for e in f.events],
        f.dt,
    )


def assert_same_frames(a: list, b: list) -> None:
    assert len(a) == len(b)
    for k, (x, y) in enumerate(zip(a, b)):
        for (name, order), u, v in zip(FIELDS, x, y):
            worst = float(np.abs(u - v).max())
            assert worst <= TOLERANCE * (2.0 / x[-1]) ** order, f"tick {k}: {name} differs by {worst}"
        corrected = (x[-3] is None, y[-3] is None)
        assert corrected[0] == corrected[1] and (corrected[0] or np.array_equal(x[-3], y[-3])), f"tick {k}"
        assert x[-2] == y[-2], f"tick {k}: events differ"


def segments(session: EngineSession) -> list[list[str]]:
    core = session.engine.apu.core
    return [[op.block.node_id for op in entry[1].ops] for entry in core.plan if entry[0] == "core"]


@pytest.mark.parametrize("name", ["breathe-anything", "idle", "greet", "interactive"])
def test_the_core_agrees_with_the_blocks_on_every_shipped_program(monkeypatch, robot, name):
    runs, notes = {}, {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, program(name), core)
        notes[core] = []
        session.on_note(
            lambda n, seen=notes[core], e=session.engine: seen.append((e.seq, n))
        )  # (in its tick)
        runs[core] = [frame_tuple(f) for f in scripted_ai.run(session, 10.0)]
        if core:
            compiled = segments(session)
            rebinds = session.engine.apu.core.rebinds
            assert session.engine.tail._made is not None  # plain ticks took the compiled tail
    assert_same_frames(runs[True], runs[False])
    # the blocks' notes too, in the same ticks: a look_at's end (the gaze's watch), clips and postures
    # started and done
    assert notes[True] == notes[False]
    if name == "interactive":
        assert any(n.get("node") == "gaze" and n.get("event") == "completed" for _, n in notes[True])
    moved = np.ptp(np.array([f[0] for f in runs[True]]), axis=0)
    assert moved.max() > 0.01  # the program moved the robot: the comparison covered motion
    assert rebinds == 0
    # the compiled blocks run in one kernel call: the Python blocks run first, then the whole core (the
    # interactive program's clip player reads the emotion's speed in the kernel)
    assert len(compiled) == 1, compiled
    assert "mix" in compiled[-1] and "output" in compiled[-1]
    if name == "interactive":
        assert {"gaze", "breathe", "mood", "emotion", "breath_amplitude", "gesture"} <= set(compiled[0])
        assert {"look_at", "nmf", "safety"} <= set(compiled[0])


def _edits(session: EngineSession, k: int, other: dict) -> None:
    """A live session's life: slider edits, mixer commands, a swap away and back, a reset."""
    if k in (20, 100, 210):  # the emotion moves (in the kernel), and with it what it drives
        session.execute({"type": "set_input", "name": "valence", "value": [0.8, -0.6, 0.3][k % 3]})
        session.execute({"type": "set_input", "name": "arousal", "value": [-0.5, 0.9, 0.0][k % 3]})
    if k == 40:
        session.update_params("emotion", {"smoothing": 0.2, "hysteresis": 0.3, "droop": 0.3})
        session.update_params("breath_amplitude", {"op": "map_range", "out_min": 0.01, "out_max": 0.06})
    if k == 50:
        session.update_params("breathe", {"frequency": 0.9, "amplitude": 0.05})
        session.update_params("mood", {"gain": 1.4})
        session.update_params("nmf", {"preset": "D"})
    elif k == 80:
        session.execute(
            {"type": "set_layer", "mixer": "mix", "layer": "wander", "active": False, "fade": 0.2}
        )
    elif k == 120:
        session.update_params("wander", {"amplitude": 0.08})
        session.update_params("safety", {"velocity_scale": 0.5})
    elif k == 150:
        session.load_program(other)  # a hot swap: the blocks of the same id keep their state
    elif k == 200:
        session.load_program(program("interactive"))
    elif k == 260:
        session.reset()


def test_edits_commands_swaps_and_resets_keep_both_paths_together(monkeypatch, robot):
    other = program("idle")
    runs = {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, program("interactive"), core)
        session.engine.apu.cook.every = 7  # the blocks' own ticks often, between the core's
        frames = []
        for k in range(320):
            _edits(session, k, other)
            frames.append(frame_tuple(session.engine.tick()))
        runs[core] = frames
        if core:
            assert session.engine.apu.core is not None and session.engine.apu.core.rebinds == 0
    assert_same_frames(runs[True], runs[False])


def test_a_replaced_array_is_found_and_bound_again(monkeypatch, robot):
    session = session_for(monkeypatch, robot, program("breathe-anything"), True)
    engine = session.engine
    engine.run_ticks(5)
    limiter = engine.apu.block("safety")
    limiter.state.last = limiter.state.last.copy()  # unannounced: the same state object, a new array
    engine.apu.cook.every = 1  # the next tick is a timed one, which verifies the table
    engine.tick()
    assert engine.apu.core.rebinds == 1
    engine.apu.cook.every = 10**9
    engine.tick()
    # the kernel steps the block's new array: the frame out is what the block now holds
    out = engine.apu.signal_value("safety", "out")
    assert np.array_equal(out.values, limiter.state.last)
    (op,) = [op for op in engine.apu.core.ops if op.block is limiter]
    assert engine.apu.core.listed(op, 1)[0] is limiter.state.last


def test_the_hot_path_allocates_nothing_that_grows(monkeypatch, robot):
    session = session_for(monkeypatch, robot, program("breathe-anything"), True)
    # tracemalloc counts every thread: every session's sounds warming on its own thread, this one's
    # and the earlier tests', and any kernel still loading, would be counted as the tick's allocations
    for thread in threading.enumerate():
        if thread.name in ("nutty-sounds", "nutty-warm-up") or thread.name.startswith("nutty-load-"):
            thread.join(timeout=60)
    apu = session.engine.apu
    apu.cook.every = 10**9  # every tick through the core
    for _ in range(200):
        apu.tick(0.01)
    tracemalloc.start()
    try:
        start, _ = tracemalloc.get_traced_memory()
        for _ in range(1000):
            apu.tick(0.01)
        end, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # nothing kept (a counter past the small integers aside), and no tick holds more than ~1 kB at once:
    # no frame, mask or events list is made per tick (numba's per-call argument wrappers are the rest)
    assert end - start <= 1024, end - start
    assert peak - start <= 2048, peak - start


# --- random programs --------------------------------------------------------------------------------

SOURCES = ("rest_pose", "breathe", "noise", "sine", "led")
OPERATORS = ("gain_offset", "motion_filter", "mask")


@st.composite
def random_program(draw) -> dict:
    """Layers of sources and operators (compiled and Python ones mixed), a mixer, a stage 2, the output;
    some parameters driven by an LFO (a Python signal block)."""
    b = ProgramBuilder("random")
    lfo = b.node("lfo", "lfo", frequency=draw(st.floats(0.1, 3.0)), amplitude=0.5, offset=0.5)
    layers, names = [], []
    for i in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(SOURCES))
        params: dict = {}
        if kind == "breathe":
            params = {"frequency": draw(st.floats(0.05, 2.0)), "amplitude": draw(st.floats(0.0, 0.2))}
        elif kind == "noise":
            params = {"amplitude": draw(st.floats(0.0, 0.1)), "tau": draw(st.floats(0.1, 3.0))}
            params["smoothing"] = draw(st.sampled_from([0.0, 0.2]))
        elif kind == "sine":
            params = {"amplitude": draw(st.floats(0.0, 0.5)), "frequency": draw(st.floats(0.1, 2.0))}
        elif kind == "led":
            params = {
                "mode": draw(st.sampled_from(["solid", "breathe", "pulse"])),
                "frequency": draw(st.floats(0.0, 10.0)),
                "depth": draw(st.floats(0.0, 1.0)),
                "colour": draw(st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3)),
            }
        chain = [b.node(kind, f"src{i}", **params)]
        if kind == "breathe" and draw(st.booleans()):
            b.connect(lfo, chain[0], "value", "amplitude")
        if kind == "led" and draw(st.booleans()):
            b.connect(lfo, chain[0], "value", draw(st.sampled_from(["depth", "frequency"])))
        for j in range(draw(st.integers(0, 2))):
            op = draw(st.sampled_from(OPERATORS))
            if op == "gain_offset":
                node = b.node(
                    op, f"op{i}_{j}", gain=draw(st.floats(-1.5, 1.5)), offset=draw(st.floats(-0.2, 0.2))
                )
                if draw(st.booleans()):
                    b.connect(lfo, node, "value", "gain")
            elif op == "motion_filter":
                node = b.node(op, f"op{i}_{j}", preset=draw(st.sampled_from(["A", "B", "C", "D"])))
            else:
                node = b.node(op, f"op{i}_{j}", dofs=[draw(st.sampled_from(["head_*", "*", "stationary:*"]))])
            chain.append(node)
        b.chain(*chain)
        layers.append(chain[-1])
        names.append(f"l{i}")
    modes = [draw(st.sampled_from(["override", "additive", "average"])) for _ in layers]
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[
            {"name": n, "mode": m, "weight": draw(st.floats(0.0, 1.0)), "fade": draw(st.floats(0.0, 1.0))}
            for n, m in zip(names, modes)
        ],
    )
    for node, name in zip(layers, names):
        b.connect(node, mix, "out", name)
    if draw(st.booleans()):
        b.connect(lfo, mix, "value", f"{names[0]}_weight")
    stage2 = [mix]
    if draw(st.booleans()):
        stage2.append(b.node("nmf_stage2", "nmf", preset=draw(st.sampled_from(["A", "B", "C", "D"]))))
    if draw(st.booleans()):
        stage2.append(b.node("safety_limiter", "safety", velocity_scale=draw(st.floats(0.1, 1.0))))
    b.chain(*stage2, b.output())
    return b.to_dict()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(prog=random_program(), command_at=st.integers(0, 59))
def test_random_programs_agree(monkeypatch, robot, prog, command_at):
    runs = {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, prog, core)
        frames = []
        for k in range(60):
            if k == command_at:
                session.execute({"type": "set_layer", "mixer": "mix", "layer": "l0", "active": k % 2 == 0})
            frames.append(frame_tuple(session.engine.tick()))
        runs[core] = frames
    assert_same_frames(runs[True], runs[False])


STEADY_VALUES = (0.0, -0.0, 0.5, 0.5, 1, 1.0, -0.25, 1e-300)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(changes=st.lists(st.tuples(st.integers(0, 39), st.sampled_from(STEADY_VALUES)), max_size=6))
def test_steady_signals_and_their_changes_agree(monkeypatch, robot, changes):
    """An op works its scalars out again only when a wired signal's value changes (same_value): an
    exposed input held, set to the same value, to an int of the same value, or across a zero's sign."""
    b = ProgramBuilder("steady")
    g = b.expose("g", "float", default=0.5)
    src = b.node("sine", "src", amplitude=0.3, frequency=0.7)
    go = b.node("gain_offset", "go", gain=1.0, offset=0.0)
    breathe = b.node("breathe", "breathe", amplitude=0.05)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}, {"name": "b", "mode": "additive"}])
    b.chain(src, go)
    for port, dst in (("gain", go), ("offset", go), ("amplitude", breathe), ("a_weight", mix)):
        b.connect(g, dst, "value", port)
    b.connect(go, mix, "out", "a").connect(breathe, mix, "out", "b")
    b.chain(mix, b.output())
    prog = b.to_dict()
    runs = {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, prog, core)
        frames = []
        for k in range(40):
            for value in [v for at, v in changes if at == k]:
                session.execute({"type": "set_input", "name": "g", "value": value})
            frames.append(frame_tuple(session.engine.tick()))
        runs[core] = frames
    assert_same_frames(runs[True], runs[False])


def test_an_led_agrees_through_commands_wired_colours_and_edits(monkeypatch, robot):
    """The LED op: set_led commands, a wired colour (which wins over them), a wired depth, and a mode
    edit; the op's phase stays the block's through its timed ticks."""
    b = ProgramBuilder("leds")
    colour = b.expose("c", "colour", default=[0.2, 0.4, 0.6])
    depth = b.expose("d", "float", default=0.3)
    wired = b.node("led", "wired", dof="eye_leds", mode="pulse", frequency=1.7, depth=0.5)
    plain = b.node("led", "plain", dof="eye_leds", mode="breathe", frequency=0.9)
    mix = b.node("layer_mixer", "mix", layers=[{"name": "a"}, {"name": "b", "mode": "average"}])
    b.connect(colour, wired, "value", "colour").connect(depth, wired, "value", "depth")
    b.connect(wired, mix, "out", "a").connect(plain, mix, "out", "b")
    b.chain(mix, b.output())
    script = {
        10: {"type": "set_led", "colour": [1.0, 0.0, 0.5]},
        20: {"type": "set_input", "name": "c", "value": [0.9, 0.8, 0.1]},
        30: {"type": "set_input", "name": "d", "value": 0.9},
    }
    runs = {}
    for core in (True, False):
        session = session_for(monkeypatch, robot, b.to_dict(), core)
        session.engine.apu.cook.every = 7
        if core:
            assert "plain" in segments(session)[0] and "wired" in segments(session)[0]
        frames = []
        for k in range(90):
            if k in script:
                session.execute(script[k])
            if k == 45:
                with pytest.raises(ValueError, match="expects a list of 3 numbers"):  # changes nothing
                    session.execute({"type": "set_input", "name": "c", "value": [2.0, 0.0]})
            if k == 60:
                session.update_params("plain", {"mode": "pulse", "depth": 0.8})
            frames.append(frame_tuple(session.engine.tick()))
        runs[core] = frames
    assert_same_frames(runs[True], runs[False])
    leds = np.array([f[0][robot.dof("eye_leds").channels] for f in runs[True]])
    assert np.ptp(leds, axis=0).min() > 0.05  # the colours moved: the comparison covered brightness


def test_same_value_tells_what_a_block_could_tell_apart():
    from backend.engine.core.ops import same_value  # lazy: the core's rule, tested alone

    assert same_value(0.5, 0.5) and same_value([1.0, 2.0], [1.0, 2.0]) and same_value("a", "a")
    assert not same_value(0.0, -0.0) and not same_value(float("nan"), float("nan"))
    assert not same_value([0.0], [-0.0]) and not same_value(1, 1.0) and not same_value(None, 0.0)
    array = np.ones(3)
    assert not same_value(array, array)  # a block may write into the array it sent last tick


def test_probes_read_a_snapshot_that_later_ticks_leave_alone(monkeypatch, robot):
    session = session_for(monkeypatch, robot, program("breathe-anything"), True)
    engine = session.engine
    engine.apu.cook.every = 10**9
    engine.run_ticks(20)
    live = engine.apu.signal_value("breathe", "out")
    with engine.tick_lock:  # as telemetry reads them: between ticks
        (snapshot,) = engine.apu.signal_values([("breathe", "out")])
    before = snapshot.values.copy()
    engine.tick()
    assert np.array_equal(snapshot.values, before)  # a copy of one tick
    assert not np.array_equal(live.values, before)  # the core rewrites its frames in place


def test_an_import_copies_a_steady_frame_once_and_any_other_frame_every_tick():
    arena = Arena(rows=1, channels=3, n_ops=1)
    imp = Import(0, 0, "out", arena)
    plain = PartialFrame(np.array([1.0, 2.0, 3.0]), np.array([True, False, True]), [])
    assert not imp.load([{"out": plain}])
    assert arena.V[0].tolist() == [1.0, 2.0, 3.0] and arena.A[0]
    plain.values[:] = [4.0, 5.0, 6.0]  # the same object rewritten in place (a compiled step's frame)
    imp.load([{"out": plain}])
    assert arena.V[0].tolist() == [4.0, 5.0, 6.0]
    steady = SteadyFrame(np.array([7.0, 8.0, 9.0]), np.array([False, True, False]), [])
    imp.load([{"out": steady}])
    assert arena.V[0].tolist() == [7.0, 8.0, 9.0] and arena.M[0].tolist() == [False, True, False]
    arena.V[0] = 0.0  # not written again while the same steady frame comes in...
    imp.load([{"out": steady}])
    assert arena.V[0].tolist() == [0.0, 0.0, 0.0] and arena.A[0]
    imp.load([{}])  # ...and a tick without a frame clears the row's presence
    assert not arena.A[0]
    imp.load([{"out": steady}])  # the same frame after a gap is copied again
    assert arena.V[0].tolist() == [7.0, 8.0, 9.0] and arena.A[0]


def test_sources_without_signals_step_in_the_kernel_alone(monkeypatch, robot):
    """Breathing and noise with nothing wired run no Python per tick: the kernel steps the breath's
    phase and the noise's draws, and asks for the next batch of draws when one is used up."""
    session = session_for(monkeypatch, robot, program("breathe-anything"), True)
    engine = session.engine
    engine.apu.cook.every = 10**9
    engine.run_ticks(3)  # the core runs from the second tick
    (seg,) = [entry[1] for entry in engine.apu.core.plan if entry[0] == "core"]
    assert seg.pres == []
    draws = engine.apu.block("wander").state.draws
    breath = engine.apu.block("breathe").state
    used = []
    for _ in range(70):
        phi = breath.phi
        engine.tick()
        used.append(draws.used)
        assert breath.phi == (phi + breath_frequency(session) * engine.dt) % 1.0
    assert 0 not in used[:1] and all(0 <= u < len(draws.batch) for u in used)
    assert used.count(0) == 2  # each batch refilled as its last draw was taken, never read used up
    assert all(b == (a + 1) % len(draws.batch) for a, b in zip(used, used[1:]))


def breath_frequency(session: EngineSession) -> float:
    return float(session.engine.apu.block("breathe").params.frequency)


def test_a_used_up_batch_of_draws_is_an_error_not_a_read_past_it(monkeypatch, robot):
    session = session_for(monkeypatch, robot, program("breathe-anything"), True)
    engine, notes = session.engine, []
    session.on_note(notes.append)
    engine.apu.cook.every = 10**9
    engine.run_ticks(3)
    held = engine.last_frame.position.copy()
    draws = engine.apu.block("wander").state.draws
    draws.cursor[0] = len(draws.batch)  # what no path leaves behind: the kernel must not read past it
    frame = engine.tick()
    assert np.array_equal(frame.program, held)  # the program's frame is the last pose: the clock lives on
    assert any("used-up batch" in n.get("message", "") for n in notes if n.get("event") == "error")
