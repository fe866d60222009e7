"""The sinks' fan-out: the clock hands each frame over once, and a thread of its own offers it to
every sink (backend/engine/sinks.py's FanOut)."""

from __future__ import annotations

import threading
import time

import pytest

from backend.engine.runtime import Engine, Sink
from backend.engine.sinks import FanOut
from backend.graph.compiler import compile_or_raise
from tests.test_runtime import level2


class Recording(Sink):
    """Keeps every frame, and the thread each was offered on."""

    def __init__(self, name: str):
        self.frames: list = []
        self.offered_on: set[str] = set()
        super().__init__(name, self.frames.append, max_queue=10_000)

    def offer(self, frame):
        self.offered_on.add(threading.current_thread().name)
        super().offer(frame)


@pytest.fixture
def engine(desk):
    eng = Engine(desk, rate=100)
    eng.load(compile_or_raise(level2().build(), desk).apu)
    yield eng
    eng.close()


def test_the_clock_offers_no_sink_itself(engine):
    """Three sinks, one hand-over per tick: every offer is made on the fan-out's thread, and every sink
    gets every frame in order."""
    sinks = [engine.add_sink(Recording(f"s{k}")) for k in range(3)]
    engine.run_ticks(50)
    assert engine.flush_sinks()
    for sink in sinks:
        assert sink.offered_on == {"sink-fan-out"}
        assert sink.offered == 50
    engine.close()
    for sink in sinks:
        assert [f.seq for f in sink.frames] == list(range(50))


def test_a_removed_sink_has_every_frame_made_before(engine):
    gone, stays = engine.add_sink(Recording("gone")), engine.add_sink(Recording("stays"))
    engine.run_ticks(30)
    engine.remove_sink(gone)  # (without a flush first, frames still in the fan-out would miss it)
    engine.run_ticks(10)
    engine.close()
    assert [f.seq for f in gone.frames] == list(range(30))
    assert [f.seq for f in stays.frames] == list(range(40))


def test_close_delivers_every_frame_made(engine):
    """A burst of ticks (a headless run) reaches a sink whole: the fan-out drops nothing it can hold."""
    sink = engine.add_sink(Recording("all"))
    engine.run_ticks(500)
    engine.close()
    assert [f.seq for f in sink.frames] == list(range(500)) and engine.stats()["sinks"][0]["dropped"] == 0


def test_frames_carry_the_wall_time_of_their_tick(engine):
    before = time.time()
    frame = engine.tick()
    assert frame.made is not None and before <= frame.made <= time.time()


def test_a_sink_removed_from_inside_a_hand_over_does_not_wait_for_itself(engine):
    """The fan-out's flush returns at once on its own thread (else removing a sink from an offer would
    wait for the hand-over that is making it)."""
    victim = engine.add_sink(Recording("victim"))
    took: list[float] = []

    class Remover(Sink):
        def offer(self, frame):
            if frame.seq == 3:
                t0 = time.perf_counter()
                engine.remove_sink(victim)
                took.append(time.perf_counter() - t0)
            super().offer(frame)

    engine.add_sink(Remover("remover", lambda f: None))
    engine.run_ticks(10)
    assert engine.flush_sinks()
    assert len(took) == 1 and took[0] < 0.4  # (the flush's timeout is 0.5 s)
    assert victim.frames and victim.frames[-1].seq <= 3


def test_idle_and_flush_follow_the_frames_in_flight():
    release = threading.Event()
    seen: list[int] = []

    def consume(item: int) -> None:
        release.wait(10)
        seen.append(item)

    slow: Sink[int] = Sink("slow", consume, max_queue=8)
    fan: FanOut[int] = FanOut(lambda: [slow])
    assert fan.idle() and fan.flush(0.1)
    fan.offer(1)
    fan.offer(2)
    assert fan.flush(1.0)  # handed over to the slow sink, which still sits on the first
    assert fan.idle() and not slow.idle()
    release.set()
    slow.close()
    fan.close()
    assert seen == [1, 2] and slow.idle()


def test_a_sink_whose_offer_fails_costs_the_others_nothing(engine):
    class Broken(Sink):
        def offer(self, frame):
            raise RuntimeError("no room")

    engine.add_sink(Broken("broken", lambda f: None))
    good = engine.add_sink(Recording("good"))
    engine.run_ticks(20)
    assert engine.flush_sinks()
    stats = engine.stats()["fan_out"]  # (what /api/status says as `fan_out`)
    assert stats["errors"] == 20 and "broken: RuntimeError: no room" in stats["last_error"]
    assert stats["dropped"] == 0 and stats["delivered"] == 20
    engine.close()
    assert [f.seq for f in good.frames] == list(range(20))


def test_no_fan_out_before_the_first_sink(engine):
    engine.run_ticks(3)
    assert engine.stats()["fan_out"] is None and engine.flush_sinks()


def test_a_failed_offer_does_not_make_the_fan_out_look_idle():
    """A sink's failed offer is counted as an error of the fan-out, but the frame is still being handed
    to the sinks after it: until that ends the fan-out is not idle, and a flush waits for it."""
    entered, release = threading.Event(), threading.Event()

    class Broken(Sink):
        def offer(self, frame):
            raise RuntimeError("no room")

    class Blocking(Sink):
        def offer(self, frame):
            entered.set()
            release.wait(10)
            super().offer(frame)

    broken: Sink[int] = Broken("broken", lambda f: None)
    blocking: Sink[int] = Blocking("blocking", lambda f: None)
    fan: FanOut[int] = FanOut(lambda: [broken, blocking])
    fan.offer(1)
    assert entered.wait(5)  # the hand-over of frame 1 is past the broken sink, inside the blocking one
    assert not fan.idle() and not fan.flush(0.05)
    release.set()
    assert fan.flush(1.0) and fan.errors == 1 and fan.delivered == 1
    for sink in (fan, broken, blocking):
        sink.close()
