"""The robot-side bridge's core: frames from a remote engine to local drivers, never faster than the
robot's limits, and to rest by itself when the frames stop (`nutty bridge`, docs/fleet.md).

`FrameRelay` knows nothing of the network: `receive(doc, sent, session)` takes one frame document (the
`/ws/frames` content) as it arrives, `tick(now)` runs on its own clock. The robot's description and
limits are the bridge's own (local files, never the network's word). Every frame it hands to the
drivers comes out of a local `SafetyNet` (backend/engine/safety.py), stepped once per delivered
frame at the fixed tick `h = 1/rate`, and **the drivers get one frame per tick, never two within
`MIN_GAP` ticks** (the bridge's clock, not the network's arrival pattern, sets the pace):

- live, a frame is delivered as it arrives (no jitter buffer, no added latency) unless the last
  delivery was less than `MIN_GAP·h` ago, in which case it waits for the tick; the engine's frames
  already respect the limits, so the net passes them through bit for bit;
- frames lost on the way or late: when no frame has come `h + grace` after the last delivery, the net
  is stepped toward the last frame's pose and that step is delivered as its own frame (dt = h, its own
  seq): the motors never freeze on a set-point while moving, and a gap is bridged tick by tick;
- when no frame has come for `timeout` seconds, the net's target becomes the rest pose: the robot
  decelerates from the last *delivered* state and settles at rest within its velocity, acceleration
  and jerk limits, then rest is held (sent at the frame rate): a network fault never leaves the motors
  on the last set-point;
- when frames come back, the target is the engine's frame again and the net brings the robot there
  within the same limits (no jump), then passes the frames through once more.

Frames are followed per engine *session* (an id the engine draws at start, `backend.zenoh_link`): a
new session (a restarted engine) starts its sequence numbers afresh, and a sequence number further
ahead than the time since the last frame allows is refused (counted as `implausible`), so forged high
numbers lock nobody out. Before the first frame nothing is sent: the bridge assumes the robot rests
where it is. It counts what it sees: frames, gaps and missed frames, held ticks, stale, implausible,
foreign and rejected frames, timeouts and resumes, the latency from the engine's emission stamp to
arrival (ms), and the longest silence.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.frames import FrameEvent
from backend.engine.net_frames import NetFrames
from backend.engine.runtime import RingStats, Sink
from backend.engine.safety import SafetyNet
from backend.zenoh_link.codec import FrameDoc

DEFAULT_TIMEOUT = 0.25  # s without a frame before the robot is taken to rest
MIN_TIMEOUT, MAX_TIMEOUT = 0.02, 10.0
#: Two deliveries are at least this many ticks apart (a frame that comes sooner waits for the tick).
MIN_GAP = 0.95
#: A frame later than h + max(h, GRACE) after the last delivery is bridged by a held step (s).
GRACE = 0.005
WAITING, LIVE, RESTING, AT_REST = "waiting", "live", "resting", "at rest"

logger = logging.getLogger(__name__)


class FrameRelay:
    """Engine frames in, limited frames out to `sinks` (see the module doc).

    emb: the robot (from local files); rate: the engine's tick rate (Hz, 30..1000), which the net and the
    relay's clock run at; timeout: seconds of silence before resting (MIN_TIMEOUT..MAX_TIMEOUT, at least
    two ticks). `clock` (monotonic s) and `wall` (Unix s, compared with the engine's stamps) can be
    replaced in tests. `log`: a callable given each message the relay has to say; by default they go
    to this module's logger (INFO, or WARNING for refused frames and timeouts).
    """

    def __init__(
        self,
        emb: Embodiment,
        rate: float,
        sinks: list[Sink],
        *,
        timeout: float = DEFAULT_TIMEOUT,
        clock: Callable[[], float] = time.monotonic,
        wall: Callable[[], float] = time.time,
        log: Callable[[str], None] | None = None,
    ):
        if not 30.0 <= rate <= 1000.0:
            raise ValueError(f"rate must be within 30..1000 Hz, got {rate:g}")
        if not MIN_TIMEOUT <= timeout <= MAX_TIMEOUT or timeout < 2.0 / rate:
            raise ValueError(
                f"timeout must be within {MIN_TIMEOUT:g}..{MAX_TIMEOUT:g} s and at least two ticks "
                f"({2.0 / rate:g} s), got {timeout:g}"
            )
        self.emb, self.sinks, self.timeout = emb, list(sinks), float(timeout)
        self.clock, self.wall = clock, wall
        self.log = log  # None: through logging (see _note)
        self.mode = WAITING
        self.parking = False  # set by park(): frames are ignored, the robot goes to rest
        self._lock = threading.RLock()
        self._wake = threading.Event()  # a frame is waiting for the tick
        self._set_rate(rate, emb.rest)
        self._target = emb.rest.copy()  # the engine's last frame (positions, all channels)
        self._events: list[FrameEvent] = []  # of frames received but not yet delivered
        self._pending = False  # a received frame is not delivered yet
        self._holding = False  # the last delivery was a held step (no frame had come)
        self._last_sent: float | None = None  # clock time of the last delivery
        self.out = NetFrames(emb)  # the delivered state, and the frames made from the net's output
        self.t, self.seq = 0.0, 0  # of the frames sent (s; count)
        self.session: str | None = None  # the engine session followed
        self.last_seq: int | None = None
        self.last_rx: float | None = None
        self.latency = RingStats()
        self.counts: dict[str, int] = dict.fromkeys(
            (
                "received",
                "sent",
                "gaps",
                "missed",
                "held",
                "stale",
                "implausible",
                "foreign",
                "rejected",
                "timeouts",
                "resumes",
                "restarts",
            ),
            0,
        )
        self.longest_silence = 0.0  # s between two frames received
        self._started = clock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _set_rate(self, rate: float, start: np.ndarray) -> None:
        self.rate, self.h = float(rate), 1.0 / float(rate)
        self.grace = max(self.h, GRACE)
        self.net = SafetyNet(self.emb, rate, start=start)
        # Load the net's compiled correction now, not on the first frame that needs it (that takes a
        # second or more, and the frames behind it would pile up): a throwaway net corrects a jump.
        warm = SafetyNet(self.emb, rate, start=self.emb.rest)
        warm.step(
            np.where(warm.mask, np.clip(self.emb.rest + 0.1, self.emb.min, self.emb.max), self.emb.rest)
        )

    # --- frames in --------------------------------------------------------------------------------
    def receive(self, doc: dict[str, Any], sent: float | None = None, session: str | None = None) -> None:
        """One engine frame document, as it arrives (any thread); `sent`: the engine's emission stamp;
        `session`: the engine session it came from (the follower passes only the running engine's)."""
        now = self.clock()
        with self._lock:
            if self.parking:
                return
            try:
                frame = FrameDoc.parse(doc, self.emb, self._target)
            except (ValueError, TypeError) as exc:
                self.reject(str(exc))
                return
            if session != self.session:
                if self.session is not None:
                    self.counts["restarts"] += 1
                    self._note(
                        logging.INFO,
                        f"a new engine session ({session}): following it from seq {frame.seq}",
                    )
                self.session, self.last_seq = session, None
            if not self._plausible(frame.seq, now):
                return
            if abs(frame.dt * self.rate - 1.0) > 0.01:
                self._note(
                    logging.INFO,
                    f"the engine now ticks at {1.0 / frame.dt:g} Hz (was {self.rate:g}): following it",
                )
                self._set_rate(1.0 / frame.dt, self.out.pos)
            if self.mode in (RESTING, AT_REST):
                self.counts["resumes"] += 1
                self._note(
                    logging.INFO,
                    f"frames again after {now - (self.last_rx or now):.2f} s: blending back within the "
                    "robot's limits",
                )
            if self.last_rx is not None:
                self.longest_silence = max(self.longest_silence, now - self.last_rx)
            self.counts["received"] += 1
            self.last_rx, self.last_seq = now, frame.seq
            if sent is not None:
                self.latency.add(max(0.0, self.wall() - sent))
            self._target = frame.position
            self._events += frame.events
            self._pending, self._holding = True, False
            self.mode = LIVE
            if self._last_sent is None or now - self._last_sent >= MIN_GAP * self.h:
                self._deliver(now)
            else:
                self._wake.set()  # too soon after the last delivery: the clock delivers it at the tick

    def _plausible(self, seq: int, now: float) -> bool:
        """Count a stale or implausible sequence number (False), or a gap (True, as every acceptable one)."""
        if self.last_seq is None:
            return True
        if seq <= self.last_seq:
            if self.mode == LIVE:
                self.counts["stale"] += 1  # late or repeated: the robot has moved on
                return False
            self.last_seq = None  # resting: an engine that started again counts from 0
            return True
        ahead = seq - self.last_seq
        allowed = (now - (self.last_rx or now) + self.timeout) * self.rate + 2
        if ahead > allowed:
            self.counts["implausible"] += 1
            if self.counts["implausible"] in (1, 10, 100, 1000):
                self._note(
                    logging.WARNING,
                    f"a frame {ahead} ahead of the last one ({self.last_seq}) cannot be this engine's so "
                    f"soon: refused ({self.counts['implausible']} so far)",
                )
            return False
        if ahead > 1:
            self.counts["gaps"] += 1
            self.counts["missed"] += ahead - 1
        return True

    def reject(self, why: str, kind: str = "rejected") -> None:
        """Count a message that is not a usable frame (`kind`: rejected, or foreign for a frame that is not
        the running engine's); logged the 1st, 10th, 100th and 1000th time."""
        self.counts[kind] += 1
        if self.counts[kind] in (1, 10, 100, 1000):
            self._note(logging.WARNING, f"frame {kind} ({self.counts[kind]} so far): {why}")

    def _note(self, level: int, message: str) -> None:
        """Say what the relay did: to the `log` callable when one was given, else to the logger."""
        if self.log is not None:
            self.log(message)
        else:
            logger.log(level, message)

    # --- the clock --------------------------------------------------------------------------------
    def tick(self, now: float | None = None) -> None:
        """On the relay's clock: deliver a frame that waited for the tick, bridge a late one with a held
        step, notice a silence longer than the timeout, and while resting step toward rest."""
        now = self.clock() if now is None else now
        with self._lock:
            if self.mode == LIVE and (self.parking or now - (self.last_rx or now) > self.timeout):
                self.mode = RESTING
                if not self.parking:
                    self.counts["timeouts"] += 1
                    self._note(
                        logging.WARNING,
                        f"no frame for {now - (self.last_rx or now):.2f} s (timeout {self.timeout:g} s): taking the "
                        "robot to rest within its limits",
                    )
            if self.mode == LIVE:
                if now >= (self._last_sent or now) + self._live_step():
                    self._holding = not self._pending
                    if self._holding:
                        self.counts["held"] += 1
                    self._deliver(now)
            elif self.mode in (RESTING, AT_REST):
                if self._last_sent is None or now - self._last_sent >= MIN_GAP * self.h:
                    self._deliver(now)
                if self.mode == RESTING and self.at_rest():
                    self.mode = AT_REST
                    self._note(logging.INFO, "the robot is at rest; holding it there")

    def _live_step(self) -> float:
        """Seconds after the last delivery that the next one is due while live: a waiting frame at the
        tick; with none, a held step after the grace (a frame may just be late), then one a tick."""
        if self._pending:
            return MIN_GAP * self.h
        return self.h if self._holding else self.h + self.grace

    def next_due(self, now: float) -> float:
        """When `tick` next has something to do (clock time), for the relay's own loop."""
        with self._lock:
            if self._last_sent is None or self.mode == WAITING:
                return now + self.h
            if self.mode == LIVE:
                return min(self._last_sent + self._live_step(), (self.last_rx or now) + self.timeout + 1e-6)
            return self._last_sent + self.h

    def at_rest(self) -> bool:
        """Whether the last frame sent is the rest pose exactly, standing still."""
        return self.out.at_rest()

    def start(self) -> FrameRelay:
        """Run `tick` on a thread when something is due (late ticks stretch time: never faster than the rate)."""

        def loop() -> None:
            while not self._stop.is_set():
                now = self.clock()
                wait = max(0.0, min(self.next_due(now), now + self.h) - now)
                if self._wake.wait(wait):
                    self._wake.clear()
                if self._stop.is_set():
                    return
                self.tick()

        self._thread = threading.Thread(target=loop, name="bridge-clock", daemon=True)
        self._thread.start()
        return self

    def park(self, timeout: float = 3.0) -> bool:
        """Ignore frames from now on and bring the robot to rest (the clock must run); whether it got there
        within `timeout` seconds."""
        with self._lock:
            self.parking = True
            if self.mode == WAITING:  # nothing was ever sent: the robot never left rest
                return True
        deadline = time.monotonic() + timeout
        while self.mode != AT_REST and time.monotonic() < deadline:
            time.sleep(0.01)
        return self.mode == AT_REST

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(2.0)

    # --- frames out -------------------------------------------------------------------------------
    def _deliver(self, now: float) -> None:
        """One step of the net toward the engine's last frame (live) or rest, sent as one frame of one tick."""
        live = self.mode == LIVE
        target = self._target if live else self.emb.rest
        out = self.net.step(target)
        events, self._events = (self._events, []) if live else ([], self._events)
        self._pending = False
        self._last_sent = now
        self._send(out, events, target)

    def _send(self, out: np.ndarray, events: list[FrameEvent], program: np.ndarray) -> None:
        dt = self.h
        first = self.counts["sent"] == 0
        self.t = self.t + dt if not first else 0.0
        frame = self.out.frame(
            self.net, out, t=self.t, dt=dt, seq=self.seq, first=first, events=events, program=program
        )
        self.seq += 1
        self.counts["sent"] += 1
        for sink in self.sinks:
            sink.offer(frame)

    # --- reporting --------------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """What the bridge saw so far (counts; latency in ms; seconds)."""
        with self._lock:
            elapsed = max(self.clock() - self._started, 1e-9)
            lat = self.latency.summary()
            return {
                "mode": self.mode,
                **self.counts,
                "rate_in": self.counts["received"] / elapsed,
                "latency_ms": {k: lat[k] for k in ("p50_ms", "p99_ms", "max_ms")},
                "longest_silence_s": self.longest_silence,
                "corrected_ticks": int(self.net.corrected_ticks),
                "seconds": elapsed,
                "drivers": [s.stats() for s in self.sinks],
            }


def report_line(robot_id: str, s: dict[str, Any]) -> str:
    """One log line of a summary."""
    lat = s["latency_ms"]
    return (
        f"{robot_id} {s['mode']}: {s['received']} frames in ({s['rate_in']:.1f}/s), "
        f"{s['sent']} out; latency p50 {lat['p50_ms']:.2f} ms p99 {lat['p99_ms']:.2f} ms max {lat['max_ms']:.2f} ms; "
        f"gaps {s['gaps']} ({s['missed']} frames missed, {s['held']} ticks held), longest silence "
        f"{s['longest_silence_s'] * 1e3:.0f} ms; stale {s['stale']}, implausible {s['implausible']}, foreign "
        f"{s['foreign']}, rejected {s['rejected']}; timeouts {s['timeouts']}, resumes {s['resumes']}"
    )
