"""Plays a recording (backend/recording/playback.py) to drivers through the safety net, in real time.

The robot is assumed at rest. Every frame the drivers get comes out of one `SafetyNet`
(backend/engine/safety.py), stepped once per delivered frame at the fixed tick `h = dt / speed`:

1. **lead-in**: a recording that starts in motion gets a *run-up* (`run_up`): a smooth polynomial
   from a standing pose to the first frame's position, velocity and acceleration, within the limits,
   so the recorded frames then pass through exactly instead of being caught up. The net takes the
   robot from rest to the run-up's start (or the first pose), until the output has stood still for
   `STILL_TICKS` ticks, then plays the run-up;
2. **play**: the recorded frames at their own times (scaled by `speed`), with their events; a
   recording that respects the robot's limits passes through the net bit for bit, anything else is
   corrected (and counted);
3. with `loop`, a lead-in back to the first pose and the recording again, until stopped;
4. **park**: at the end, or as soon as `stop` is set (a signal), the target is the rest pose until the
   robot stands still there; `abort` (a second signal) gives up waiting.

Pacing never runs faster than the tick: a late tick (a slow driver, a busy machine) stretches time
rather than bursting frames to catch up.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.frames import FrameEvent
from backend.engine.net_frames import NetFrames
from backend.engine.runtime import Sink
from backend.engine.safety import SafetyNet
from backend.recording.playback import Recording

#: Ticks the output must stand exactly still before a lead-in or a park counts as done.
STILL_TICKS = 3
#: Longest lead-in or park (s) before the player gives up on it (a pose the limits cannot reach).
SETTLE_SECONDS = 60.0
MIN_SPEED, MAX_SPEED = 0.1, 10.0
#: Run-up lengths (s) tried, shortest first, and the share of the acceleration and jerk limits a run-up
#: may use (all of the velocity limit: a recording may start at its robot's top speed).
RUN_UP_SECONDS = (0.5, 1.0, 2.0, 4.0, 8.0)
RUN_UP_MARGIN = 0.9


def run_up(emb: Embodiment, positions: np.ndarray, h: float, governed: np.ndarray) -> np.ndarray:
    """Frames (n, C) at tick `h` (s) that go from standing still into the motion the recording starts
    with: on every `governed` channel that moves at the start, a quintic at rest at a start pose at
    time 0 that passes through the first three recorded samples at ticks n, n+1, n+2, so the run-up
    and the recording are samples of one smooth curve where they meet (their finite differences, which
    the net limits, continue). The shortest of RUN_UP_SECONDS whose samples stay within RUN_UP_MARGIN
    of the acceleration and jerk limits (within the others); no frames (0, C) when the recording starts still or none fits (the net then
    catches the recording up)."""
    x = np.vstack([positions[:3], *[positions[-1:]] * max(0, 3 - len(positions))])
    v0 = (x[1] - x[0]) / h
    a0 = (x[2] - 2 * x[1] + x[0]) / h**2
    g = governed & (np.abs(v0) + np.abs(a0) > 0)
    if not g.any():
        return np.empty((0, positions.shape[1]))
    lo, hi = emb.min[g], emb.max[g]
    limits = np.stack([emb.vel_limit[g], emb.acc_limit[g], emb.jerk_limit[g]])
    for seconds in RUN_UP_SECONDS:
        n = max(3, round(seconds / h))
        T = n * h
        # the gentlest start (a quartic velocity ramp from 0 to v0 over T), inside the range
        start = np.clip(x[0, g] - v0[g] * T / 2 + a0[g] * T * T / 12, lo, hi)
        s_end = (n + np.arange(3)) / n  # the three recorded samples, in s = t / T
        m = np.stack([s_end**3, s_end**4, s_end**5], axis=1)
        c3, c4, c5 = np.linalg.solve(m, x[:, g] - start)
        s = (np.arange(n) / n)[:, None]
        ramp = start + s**3 * (c3 + s * (c4 + s * c5))
        path = np.vstack([np.tile(start, (3, 1)), ramp, x[:, g]])  # standing, the run-up, the recording
        if (ramp >= lo).all() and (ramp <= hi).all() and _within(path, h, limits, n):
            frames = np.tile(positions[0], (n, 1))
            frames[:, g] = ramp
            return frames
    return np.empty((0, positions.shape[1]))


def _within(path: np.ndarray, h: float, limits: np.ndarray, n: int) -> bool:
    """Whether the finite differences of `path` (3 standing rows, n run-up rows, 3 recorded rows) keep
    within the (V, A, J) `limits` (A and J: within RUN_UP_MARGIN of them where they involve only run-up
    rows; the recording may use all of them)."""
    d = path
    for k in range(3):  # velocity, acceleration, jerk
        d = np.diff(d, axis=0) / h
        # row i of the k-th difference spans path rows i..i+k+1; from row n+2-k it reaches the recording
        margin = RUN_UP_MARGIN if k else 1.0
        share = np.where(np.arange(len(d)) < n + 2 - k, margin, 1.0 + 1e-9)[:, None]
        if (np.abs(d) > share * limits[k]).any():
            return False
    return True


@dataclass
class PlayStats:
    """What a play did: recorded frames delivered, ticks of lead-in and park, recorded frames the net
    corrected, loops completed, whether a signal stopped it and whether the robot ended at rest."""

    frames: int = 0
    lead_in_ticks: int = 0
    park_ticks: int = 0
    corrected: int = 0
    loops: int = 0
    stopped: bool = False
    parked: bool = False

    def as_dict(self, h: float) -> dict[str, Any]:
        return {
            **self.__dict__,
            "lead_in_s": self.lead_in_ticks * h,
            "park_s": self.park_ticks * h,
        }


class Player:
    """Plays `rec` on robot `emb` into `sinks` (see the module doc). `speed`: 1 real time, 2 twice as
    fast (the limits still hold: the net runs at the delivered tick). `stop` and `abort` are set by the
    caller's signal handlers; `clock` (monotonic s) can be replaced in tests."""

    def __init__(
        self,
        emb: Embodiment,
        rec: Recording,
        sinks: list[Sink],
        speed: float = 1.0,
        stop: threading.Event | None = None,
        abort: threading.Event | None = None,
        clock: Callable[[], float] = time.monotonic,
    ):
        if not MIN_SPEED <= speed <= MAX_SPEED:
            raise ValueError(f"speed must be within {MIN_SPEED:g}..{MAX_SPEED:g}, got {speed:g}")
        self.emb, self.rec, self.sinks = emb, rec, list(sinks)
        self.h = rec.dt / speed
        self.stop = stop or threading.Event()
        self.abort = abort or threading.Event()
        self.clock = clock
        self.net = SafetyNet(emb, 1.0 / self.h, start=emb.rest)
        self.run_up = run_up(emb, rec.positions, self.h, self.net.mask)
        self.stats = PlayStats()
        self.out = NetFrames(emb)  # the delivered state, and the frames made from the net's output
        self.t, self.seq = 0.0, 0
        self._due: float | None = None
        self._warm()

    def _warm(self) -> None:
        """Load the net's compiled correction now, not on the first frame (a second or more)."""
        warm = SafetyNet(self.emb, 1.0 / self.h, start=self.emb.rest)
        warm.step(
            np.where(warm.mask, np.clip(self.emb.rest + 0.1, self.emb.min, self.emb.max), self.emb.rest)
        )

    def run(self, loop: bool = False) -> PlayStats:
        """Lead-in, play (again with `loop`), park; returns what happened. The sinks stay open."""
        first = self.run_up[0] if len(self.run_up) else self.rec.positions[0]
        while not self.stop.is_set():
            self.stats.lead_in_ticks += self._settle(first, self.stop)
            for pose in self.run_up:
                if self.stop.is_set():
                    break
                self._send(self.net.step(pose), [], pose)
                self.stats.lead_in_ticks += 1
            if self.stop.is_set() or not self._play():
                break
            self.stats.loops += 1
            if not loop:
                break
        self.stats.stopped = self.stop.is_set()
        ticks = self._settle(self.emb.rest, self.abort)
        self.stats.park_ticks = ticks
        self.stats.parked = self.at_rest()
        return self.stats

    def at_rest(self) -> bool:
        """Whether the last frame sent is the rest pose exactly, standing still."""
        return self.out.at_rest()

    def _play(self) -> bool:
        """The recorded frames through the net; False when stopped before the end."""
        before = self.net.corrected_ticks
        rec = self.rec
        for k in range(len(rec.times)):
            if self.stop.is_set():
                self.stats.corrected += self.net.corrected_ticks - before
                return False
            self._send(self.net.step(rec.positions[k]), rec.events[k], rec.positions[k])
            self.stats.frames += 1
        self.stats.corrected += self.net.corrected_ticks - before
        return True

    def _settle(self, target: np.ndarray, interrupt: threading.Event) -> int:
        """Step the net toward `target` until the output (channels and joints) has stood still for
        STILL_TICKS ticks, `interrupt` is set, or SETTLE_SECONDS pass; returns the ticks sent."""
        still, ticks = 0, 0
        last = np.concatenate([self.out.pos, self.net.joint_out])
        limit = round(SETTLE_SECONDS / self.h)
        while still < STILL_TICKS and ticks < limit and not interrupt.is_set():
            out = self.net.step(target)
            self._send(out, [], target)
            now = np.concatenate([out, self.net.joint_out])
            still = still + 1 if np.array_equal(now, last) else 0
            last = now
            ticks += 1
        return ticks

    def _send(self, out: np.ndarray, events: list[FrameEvent], program: np.ndarray) -> None:
        """One frame of one tick to every sink, at its time (after waiting for it)."""
        self._wait()
        h = self.h
        frame = self.out.frame(
            self.net, out, t=self.t, dt=h, seq=self.seq, first=self.seq == 0, events=events, program=program
        )
        for sink in self.sinks:
            sink.offer(frame)
        self.seq += 1
        self.t = self.seq * h

    def _wait(self) -> None:
        """Sleep until this tick is due; a tick more than one late restarts the schedule from now."""
        now = self.clock()
        if self._due is None or now > self._due + self.h:
            self._due = now
        elif self._due > now:
            self.abort.wait(self._due - now)  # a second signal cuts the wait short
        self._due += self.h
