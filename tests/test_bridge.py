"""The robot-side bridge's core (backend/bridge.py FrameRelay), driven by a real engine's frames and a
simulated clock: pass-through, rest on silence within the limits, blend back, gaps and bad frames."""

from __future__ import annotations

import numpy as np
import pytest

from backend.bridge import AT_REST, LIVE, RESTING, WAITING, FrameRelay
from backend.session import EngineSession
from backend.zenoh_link.codec import FrameDoc
from tests.test_command_registry import INTERACTIVE

RATE = 100.0
H = 1.0 / RATE


class Capture:
    """A sink that keeps every frame it is offered (in the caller's thread: deterministic)."""

    name = "capture"

    def __init__(self):
        self.frames = []

    def offer(self, frame) -> None:
        self.frames.append(frame)

    def stats(self) -> dict:
        return {"name": self.name, "delivered": len(self.frames)}


@pytest.fixture(scope="module")
def engine_frames(desk):
    """Five seconds of the interactive program (it breathes, blinks and looks around) as frame documents."""
    session = EngineSession.create(desk, rate=RATE)
    session.load_program(INTERACTIVE.read_text())
    return [f.to_dict(desk) for f in session.engine.run_ticks(int(5 * RATE))]


class Clock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def make(desk, timeout=0.1):
    clock, out = Clock(), Capture()
    relay = FrameRelay(desk, RATE, [out], timeout=timeout, clock=clock, wall=lambda: 50.0, log=lambda m: None)
    return relay, clock, out


def feed(relay, clock, docs, sent=None):
    for doc in docs:
        clock.now += H
        relay.receive(doc, sent)
        relay.tick()


def positions(frames, desk):
    return np.array([f.position[desk.continuous_mask] for f in frames])


def within_limits(desk, pos: np.ndarray) -> bool:
    """Finite differences at the tick within the robot's velocity, acceleration and jerk limits."""
    m = desk.continuous_mask
    v = np.diff(pos, axis=0) / H
    a = np.diff(v, axis=0) / H
    j = np.diff(a, axis=0) / H
    slack = 1 + 1e-9
    return bool(
        np.all(np.abs(v) <= desk.vel_limit[m] * slack)
        and np.all(np.abs(a) <= desk.acc_limit[m] * slack)
        and np.all(np.abs(j) <= desk.jerk_limit[m] * slack)
    )


def test_live_frames_pass_through_bit_for_bit(desk, engine_frames):
    relay, clock, out = make(desk)
    assert relay.mode == WAITING
    feed(relay, clock, engine_frames, sent=49.995)
    assert relay.mode == LIVE and len(out.frames) == len(engine_frames)
    sent = np.array([f.position for f in out.frames])
    got = np.array([[d["dofs"][n]["position"] for n in desk.continuous_names] for d in engine_frames])
    assert np.array_equal(
        sent[:, desk.continuous_mask], got
    )  # the engine's frames respect the limits already
    s = relay.summary()
    assert s["received"] == len(engine_frames) and s["gaps"] == s["timeouts"] == s["corrected_ticks"] == 0
    assert s["latency_ms"]["p50_ms"] == pytest.approx(5.0)  # the stamp against the wall clock


def test_silence_takes_the_robot_to_rest_within_its_limits_then_holds_it(desk, engine_frames):
    relay, clock, out = make(desk, timeout=0.1)
    feed(relay, clock, engine_frames[:300])  # three seconds: the robot is moving
    last_live = out.frames[-1].position[desk.continuous_mask]
    assert np.abs(last_live - desk.rest[desk.continuous_mask]).max() > 1e-3
    for _ in range(9):  # 90 ms of silence, within the timeout: the net holds the last pose, tick by tick
        clock.now += H
        relay.tick()
    # the first silent tick is grace (a frame may be late); then one held step per tick, never a freeze
    assert relay.mode == LIVE and len(out.frames) == 308 and relay.counts["held"] == 8
    assert all(f.dt == H for f in out.frames) and np.all(np.diff([f.seq for f in out.frames]) == 1)
    ticks = 0
    while relay.mode != AT_REST:
        clock.now += H
        relay.tick()
        ticks += 1
        assert ticks < 5 * RATE, "not at rest after five seconds"
    assert relay.counts["timeouts"] == 1
    pos = positions(out.frames, desk)
    assert within_limits(desk, pos)  # from the last set-point on: no jump, no step beyond the limits
    assert np.array_equal(pos[-1], desk.rest[desk.continuous_mask]) and relay.at_rest()
    held = len(out.frames)
    for _ in range(20):
        clock.now += H
        relay.tick()
    assert len(out.frames) == held + 20  # rest is held, sent at the frame rate
    assert all(np.array_equal(f.position, desk.rest) for f in out.frames[held:])


def test_frames_coming_back_blend_in_without_a_jump_then_pass_through(desk, engine_frames):
    relay, clock, out = make(desk, timeout=0.1)
    feed(relay, clock, engine_frames[:300])
    for _ in range(79):  # a silence: the relay rests the robot
        clock.now += H
        relay.tick()
    assert relay.mode in (RESTING, AT_REST)
    feed(relay, clock, engine_frames[380:])  # the engine went on meanwhile: its pose is elsewhere now
    assert relay.counts["resumes"] == 1 and relay.mode == LIVE
    pos = positions(out.frames, desk)
    assert within_limits(desk, pos)
    engine = np.array(
        [[d["dofs"][n]["position"] for n in desk.continuous_names] for d in engine_frames[380:]]
    )
    assert np.abs(pos[-len(engine)] - engine[0]).max() > 0.05  # it had to catch up ...
    assert np.array_equal(pos[-60:], engine[-60:])  # ... and locked on again: the engine's frames, exactly


def test_a_restarted_engine_is_followed_from_seq_zero(desk, engine_frames):
    relay, clock, _out = make(desk, timeout=0.1)
    feed(relay, clock, engine_frames[:200])
    for _ in range(200):
        clock.now += H
        relay.tick()
    assert relay.mode == AT_REST
    feed(relay, clock, engine_frames[:50])  # a new engine: its seq starts again at 0
    assert relay.mode == LIVE and relay.counts["stale"] == 0 and relay.counts["received"] == 250


def test_gaps_stale_and_foreign_frames(desk, engine_frames):
    relay, clock, out = make(desk, timeout=0.2)
    feed(relay, clock, engine_frames[:50])
    feed(relay, clock, engine_frames[53:100])  # three frames lost on the way
    assert relay.counts["gaps"] == 1 and relay.counts["missed"] == 3
    # every frame is one tick: the jump over the lost frames is the net's to spread, within the limits
    assert all(f.dt == H for f in out.frames) and len(out.frames) == 97
    assert within_limits(desk, positions(out.frames, desk))
    assert np.array_equal(out.frames[-1].position, np.array(out.frames[-1].program))  # locked again
    sent = len(out.frames)
    relay.receive(engine_frames[80])  # late: the robot has moved on
    relay.receive({**engine_frames[100], "embodiment": "other_robot"})
    relay.receive({**engine_frames[101], "dofs": {"body_yaw": {"position": float("nan")}}})
    relay.receive({"seq": "x"})
    assert len(out.frames) == sent
    assert relay.counts["stale"] == 1 and relay.counts["rejected"] == 3


def test_bad_settings_are_refused(desk):
    with pytest.raises(ValueError, match="rate"):
        FrameRelay(desk, 10.0, [])
    with pytest.raises(ValueError, match="timeout"):
        FrameRelay(desk, 100.0, [], timeout=0.015)
    with pytest.raises(ValueError, match="two ticks"):
        FrameRelay(desk, 30.0, [], timeout=0.05)


def test_park_takes_the_robot_to_rest_on_the_real_clock(desk, engine_frames):
    out = Capture()
    relay = FrameRelay(desk, RATE, [out], timeout=0.5, log=lambda m: None).start()
    try:
        for doc in engine_frames[:150]:
            relay.receive(doc)
        assert relay.park(timeout=60.0)  # generous: a busy machine stretches the relay's clock
        relay.receive(engine_frames[150])  # ignored once parking
        assert relay.counts["received"] == 150
    finally:
        relay.stop()
    assert np.array_equal(out.frames[-1].position, desk.rest)


def test_a_forged_high_sequence_number_locks_nobody_out(desk, engine_frames):
    relay, clock, out = make(desk, timeout=0.2)
    feed(relay, clock, engine_frames[:50])
    relay.receive({**engine_frames[50], "seq": 10**9})  # 200 forged frames with a huge seq once did
    for _ in range(200):
        relay.receive({**engine_frames[51], "seq": 10**9 + 1})
    assert relay.counts["implausible"] == 201 and relay.last_seq == 49
    feed(relay, clock, engine_frames[50:100])  # the real engine goes on, followed as before
    assert relay.counts["stale"] == 0 and relay.mode == LIVE
    assert np.array_equal(out.frames[-1].position, np.array(out.frames[-1].program))


def test_a_new_engine_session_restarts_the_sequence(desk, engine_frames):
    relay, clock, out = make(desk, timeout=0.2)
    for doc in engine_frames[:60]:
        clock.now += H
        relay.receive(doc, None, "a" * 32)
        relay.tick()
    for doc in engine_frames[:20]:  # the engine restarted (a new session): its seq starts again at 0
        clock.now += H
        relay.receive(doc, None, "b" * 32)
        relay.tick()
    assert relay.counts["restarts"] == 1 and relay.counts["stale"] == 0 and relay.counts["received"] == 80
    assert within_limits(desk, positions(out.frames, desk))


def test_a_burst_of_frames_is_never_delivered_faster_than_the_tick(desk, engine_frames):
    relay, clock, out = make(desk, timeout=0.5)
    feed(relay, clock, engine_frames[:50])
    clock.now += 5 * H  # a network hiccup: five frames arrive together, late
    for doc in engine_frames[50:55]:
        relay.receive(doc)
    assert len(out.frames) == 51  # the first of the burst goes out at once; the others wait for the tick
    relay.tick()
    assert len(out.frames) == 51  # still within the same tick: nothing more
    clock.now += H
    relay.tick()
    assert len(out.frames) == 52  # the newest frame of the burst, one tick later
    newest = FrameDoc.parse(engine_frames[54], desk, desk.rest).position
    assert np.array_equal(out.frames[-1].program, newest)
    assert relay.counts["received"] == 55 and relay.counts["missed"] == 0
    assert within_limits(desk, positions(out.frames, desk))  # one step per tick at most, all within limits
