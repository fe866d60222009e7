"""The robot-side bridge's core: frames from a remote engine to local drivers, never faster than the
robot's limits, and to rest by itself when the frames stop (`nutty bridge`, docs/fleet.md).

`FrameRelay` knows nothing of the network: `receive(doc, sent)` takes one frame document (the
`/ws/frames` content) as it arrives, `tick(now)` runs at the frame rate on its own clock. Every
frame it hands to the drivers comes out of a local `SafetyNet` (backend/engine/safety.py) on the
robot's description, stepped once per engine tick:

- live, the engine's frames already respect the limits, so the net passes them through bit for bit;
  a gap (frames lost on the way) is bridged by stepping the net through the missing ticks toward the
  new frame, and only the result is sent;
- when no frame has come for `timeout` seconds, the net's target becomes the rest pose: the robot
  decelerates from its last set-point and settles at rest within its velocity, acceleration and jerk
  limits, then rest is held (sent at the frame rate): a network fault never leaves the motors on the
  last set-point;
- when frames come back, the target is the engine's frame again and the net brings the robot there
  within the same limits (no jump), then passes the frames through once more.

Before the first frame nothing is sent: the bridge assumes the robot rests where it is. It counts
what it sees: frames, gaps and missed frames, stale and foreign frames, timeouts and resumes, the
latency from the engine's emission stamp to arrival (ms), and the longest silence.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any, Callable

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame, FrameEvent
from backend.engine.runtime import RingStats, Sink
from backend.engine.safety import SafetyNet
from backend.zenoh_link.codec import FrameDoc

DEFAULT_TIMEOUT = 0.25  # s without a frame before the robot is taken to rest
MIN_TIMEOUT, MAX_TIMEOUT = 0.02, 10.0
WAITING, LIVE, RESTING, AT_REST = "waiting", "live", "resting", "at rest"


class FrameRelay:
    """Engine frames in, limited frames out to `sinks` (see the module doc).

    emb: the robot; rate: the engine's tick rate (Hz, 30..1000), which the net and the resting clock
    run at; timeout: seconds of silence before resting (MIN_TIMEOUT..MAX_TIMEOUT, at least two ticks).
    `clock` (monotonic s) and `wall` (Unix s, compared with the engine's stamps) can be replaced in tests.
    """

    def __init__(self, emb: Embodiment, rate: float, sinks: list[Sink], *, timeout: float = DEFAULT_TIMEOUT,
                 clock: Callable[[], float] = time.monotonic, wall: Callable[[], float] = time.time,
                 log: Callable[[str], None] | None = None):
        if not 30.0 <= rate <= 1000.0:
            raise ValueError(f"rate must be within 30..1000 Hz, got {rate:g}")
        if not MIN_TIMEOUT <= timeout <= MAX_TIMEOUT or timeout < 2.0 / rate:
            raise ValueError(f"timeout must be within {MIN_TIMEOUT:g}..{MAX_TIMEOUT:g} s and at least two ticks "
                             f"({2.0 / rate:g} s), got {timeout:g}")
        self.emb, self.sinks, self.timeout = emb, list(sinks), float(timeout)
        self.clock, self.wall = clock, wall
        self.log = log or (lambda m: print(m, file=sys.stderr, flush=True))
        self.mode = WAITING
        self.parking = False  # set by park(): frames are ignored, the robot goes to rest
        self._lock = threading.RLock()
        self._set_rate(rate, emb.rest)
        self._target = emb.rest.copy()  # the engine's last frame (positions, all channels)
        self._pos, self._vel, self._acc = emb.rest.copy(), np.zeros(emb.n_channels), np.zeros(emb.n_channels)
        self.t, self.seq = 0.0, 0  # of the frames sent (s; count)
        self.last_seq: int | None = None
        self.last_rx: float | None = None
        self.latency = RingStats()
        self.counts = dict.fromkeys(("received", "sent", "gaps", "missed", "stale", "rejected", "timeouts",
                                     "resumes"), 0)
        self.longest_silence = 0.0  # s between two frames received
        self._started = clock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _set_rate(self, rate: float, start: np.ndarray) -> None:
        self.rate, self.h = float(rate), 1.0 / float(rate)
        self.net = SafetyNet(self.emb, rate, start=start)
        # Load the net's compiled correction now, not on the first frame that needs it (that takes a
        # second or more, and the frames behind it would pile up): a throwaway net corrects a jump.
        warm = SafetyNet(self.emb, rate, start=self.emb.rest)
        warm.step(np.where(warm.mask, np.clip(self.emb.rest + 0.1, self.emb.min, self.emb.max), self.emb.rest))

    # --- frames in --------------------------------------------------------------------------------
    def receive(self, doc: dict[str, Any], sent: float | None = None) -> None:
        """One engine frame document, as it arrives (any thread); `sent`: the engine's emission stamp."""
        now = self.clock()
        with self._lock:
            if self.parking:
                return
            try:
                frame = FrameDoc.parse(doc, self.emb, self._target)
            except (ValueError, TypeError) as exc:
                self.reject(str(exc))
                return
            resumed = self.mode in (RESTING, AT_REST)
            if self.mode == LIVE and self.last_seq is not None and frame.seq <= self.last_seq:
                self.counts["stale"] += 1  # late or repeated: the robot has moved on
                return
            if abs(frame.dt * self.rate - 1.0) > 0.01:
                self.log(f"nutty bridge: the engine now ticks at {1.0 / frame.dt:g} Hz (was {self.rate:g}): "
                         "following it")
                self._set_rate(1.0 / frame.dt, self._pos)
            steps = 1
            if self.mode == LIVE and self.last_seq is not None and frame.seq > self.last_seq + 1:
                missed = frame.seq - self.last_seq - 1
                self.counts["gaps"] += 1
                self.counts["missed"] += missed
                steps = min(missed + 1, max(1, int(self.timeout * self.rate)))
            if resumed:
                self.counts["resumes"] += 1
                self.log(f"nutty bridge: frames again after {now - (self.last_rx or now):.2f} s: blending back "
                         "within the robot's limits")
            if self.last_rx is not None:
                self.longest_silence = max(self.longest_silence, now - self.last_rx)
            self.counts["received"] += 1
            self.last_rx, self.last_seq = now, frame.seq
            if sent is not None:
                self.latency.add(max(0.0, self.wall() - sent))
            previous, self._target = self._target, frame.position
            for k in range(1, steps + 1):  # the missing ticks, on a straight line to the new frame
                target = frame.position if k == steps else previous + (frame.position - previous) * (k / steps)
                out = self.net.step(target)
            self.mode = LIVE
            self._send(out, steps, frame.events, frame.position)

    def reject(self, why: str) -> None:
        """Count a message that is not a usable frame (logged the 1st, 10th, 100th and 1000th time)."""
        self.counts["rejected"] += 1
        if self.counts["rejected"] in (1, 10, 100, 1000):
            self.log(f"nutty bridge: frame rejected ({self.counts['rejected']} so far): {why}")

    # --- the clock --------------------------------------------------------------------------------
    def tick(self, now: float | None = None) -> None:
        """Once per tick: notice a silence longer than the timeout; while resting, step toward rest."""
        now = self.clock() if now is None else now
        with self._lock:
            if self.mode == LIVE and (self.parking or now - (self.last_rx or now) > self.timeout):
                self.mode = RESTING
                if not self.parking:
                    self.counts["timeouts"] += 1
                    self.log(f"nutty bridge: no frame for {now - self.last_rx:.2f} s (timeout {self.timeout:g} s): "
                             "taking the robot to rest within its limits")
            if self.mode in (RESTING, AT_REST):
                rest = self.emb.rest
                out = self.net.step(rest)
                self._send(out, 1, [], rest)
                if self.mode == RESTING and self.at_rest():
                    self.mode = AT_REST
                    self.log("nutty bridge: the robot is at rest; holding it there")

    def at_rest(self) -> bool:
        """Whether the last frame sent is the rest pose exactly, standing still."""
        return (bool(np.array_equal(self._pos, self.emb.rest)) and not np.any(self._vel) and not np.any(self._acc))

    def start(self) -> "FrameRelay":
        """Run `tick` at the frame rate on a thread (late ticks stretch time: never faster than the rate)."""
        def loop() -> None:
            deadline = time.monotonic()
            while True:
                deadline = max(deadline + self.h, time.monotonic())
                if self._stop.wait(max(0.0, deadline - time.monotonic())):
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
        if self._thread is not None:
            self._thread.join(2.0)

    # --- frames out -------------------------------------------------------------------------------
    def _send(self, out: np.ndarray, steps: int, events: list[FrameEvent], program: np.ndarray) -> None:
        dt = steps * self.h
        first = self.counts["sent"] == 0
        vel = np.zeros_like(out) if first else (out - self._pos) / dt
        acc = np.zeros_like(out) if first else (vel - self._vel) / dt
        jerk = np.zeros_like(out) if first else (acc - self._acc) / dt
        self._pos, self._vel, self._acc = out, vel, acc
        self.t = self.t + dt if not first else 0.0
        frame = AnimationFrame(embodiment=self.emb.name, t=self.t, dt=dt, seq=self.seq, position=out, velocity=vel,
                               acceleration=acc, jerk=jerk, events=list(events),
                               corrected=self.net.corrected.copy() if self.net.corrected_any else None,
                               program=np.array(program, dtype=float), joints=self.net.joint_out)
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
            return {"mode": self.mode, **self.counts, "rate_in": self.counts["received"] / elapsed,
                    "latency_ms": {k: lat[k] for k in ("p50_ms", "p99_ms", "max_ms")},
                    "longest_silence_s": self.longest_silence, "corrected_ticks": int(self.net.corrected_ticks),
                    "seconds": elapsed, "drivers": [s.stats() for s in self.sinks]}


def report_line(robot_id: str, s: dict[str, Any]) -> str:
    """One log line of a summary."""
    lat = s["latency_ms"]
    return (f"nutty bridge: {robot_id} {s['mode']}: {s['received']} frames in ({s['rate_in']:.1f}/s), "
            f"{s['sent']} out; latency p50 {lat['p50_ms']:.2f} ms p99 {lat['p99_ms']:.2f} ms max {lat['max_ms']:.2f} ms; "
            f"gaps {s['gaps']} ({s['missed']} frames missed), longest silence {s['longest_silence_s'] * 1e3:.0f} ms; "
            f"stale {s['stale']}, rejected {s['rejected']}; timeouts {s['timeouts']}, resumes {s['resumes']}")
