"""One bus's thread: goals out at the engine's rate, present positions back at `read_hz`, faults
detected — all off the clock thread (a serial transaction takes a millisecond or more).

A `BusWorker` is a Sink of joint vectors with a queue of one: when the bus is slower than the engine,
the newest goal wins and the skipped ones are counted as dropped. After each SYNC WRITE it reads the
servos back when a read is due. A servo that flags a fault, or that has not answered validly for
`no_answer` seconds, is *held*: no more goals go to it (it keeps its last one, or stays limp if its
own protection switched its torque off), and the driver is told (`on_fault`), once per servo.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from backend.drivers.readings import SATURATED_EFFORT
from backend.engine.sinks import Sink
from backend.hardware.bus import BusReading, ServoBus
from backend.hardware.mapping import JointMap
from backend.logs import Throttle

log = logging.getLogger(__name__)
_bus_faults = Throttle(every=10.0)  # an unplugged adapter fails on every tick: logged once per 10 s

FaultHandler = Callable[["BusWorker", int, str, float], None]


class BusWorker(Sink[tuple[float, np.ndarray]]):
    """Drives one bus. Items are (engine time s, joint vector over `emb.joint_names`).

    Arrays over the bus's joints (`map` order): `commanded` (the goals last sent, rad or m),
    `measured` (the last valid reading, rad or m; NaN: never read), `effort` (-1..1, NaN: unknown),
    `active` (False: held after a fault).
    """

    def __init__(
        self, bus: ServoBus, joint_map: JointMap, read_hz: float, no_answer: float, on_fault: FaultHandler
    ):
        self.bus, self.map = bus, joint_map
        n = len(joint_map.ids)
        self.active = np.ones(n, dtype=bool)
        self.commanded = np.full(n, np.nan)
        self.measured = np.full(n, np.nan)
        self.effort = np.full(n, np.nan)
        self.read_period = 1.0 / read_hz
        self.no_answer = no_answer
        self.on_fault = on_fault
        self.writes = self.reads = self.missed = 0
        self._ids = list(joint_map.ids)  # the ids goals go to (the active ones)
        self._index_of = {servo: k for k, servo in enumerate(joint_map.ids)}  # servo id -> joint k
        self._last_answer = np.full(n, time.monotonic())
        self._next_read = 0.0
        self.t = 0.0  # the engine time (s) of the last goals: what a fault is stamped with
        self._read_at: deque[float] = deque(maxlen=256)  # monotonic times of the last reads, for read_hz
        self._lock = threading.Lock()  # readers of the arrays (status) vs this thread
        super().__init__(f"hardware {bus.kind} {bus.where}", max_queue=1)

    def seed(self, raw_positions: np.ndarray) -> None:
        """The positions read at start (raw, bus order): the first `measured`, and the first answers."""
        with self._lock:
            self.measured = self.map.to_joints(raw_positions)
            self._last_answer[:] = time.monotonic()

    def consume(self, frame: tuple[float, np.ndarray]) -> None:
        t, joints = frame
        self.t = t
        raw = self.map.to_raw(joints)
        active = self.active
        try:
            if active.all():
                self.bus.write_goals(self._ids, raw)
            elif active.any():
                self.bus.write_goals(self._ids, raw[active])
            self.writes += 1
        except Exception as exc:  # noqa: BLE001 (any SDK error, e.g. an unplugged adapter: the reads report the silence)
            self._log_bus_error("write", exc)
        with self._lock:
            self.commanded = np.where(active, joints[self.map.index], self.commanded)
        now = time.monotonic()
        if now >= self._next_read:
            # on the read grid, not `now + period`: goals come at the engine's rate, and a read waiting
            # for the next goal after its due time would otherwise lose up to a goal period every time
            self._next_read = max(self._next_read + self.read_period, now)
            self.read(now)

    def read(self, now: float) -> BusReading:
        """Read the servos once (`now`: time.monotonic()), update the measurements and hold any servo
        that faulted."""
        t = self.t
        ids = self.map.ids
        try:
            reading = self.bus.read_state(ids)
        except Exception as exc:  # noqa: BLE001 (any SDK error: as if no servo answered)
            self._log_bus_error("read", exc)
            reading = BusReading(np.full(len(ids), np.nan), np.full(len(ids), np.nan))
        index_of = self._index_of
        flagged = {index_of[s]: f for s, f in reading.faults.items() if s in index_of}
        # A servo that cannot report its position (PWM) has answered unless its board did not: its
        # `no_answer` flag, like a serial servo's missing reply, becomes a fault only after `no_answer` s.
        silent_now = np.zeros(len(ids), dtype=bool)
        silent_now[[k for k, f in flagged.items() if f == "no_answer"]] = True
        ok = np.isfinite(reading.position)
        answered = ok if self.bus.reads_position else ~silent_now
        with self._lock:
            self.measured = np.where(ok, self.map.to_joints(reading.position), self.measured)
            self.effort = np.where(ok, reading.effort, self.effort)
            self._last_answer[answered] = now
        self.reads += 1
        self.missed += int(answered.size - np.count_nonzero(answered))
        self._read_at.append(now)
        silent = (now - self._last_answer) > self.no_answer
        for k in np.flatnonzero(self.active & silent):
            self._fault(int(k), "no_answer", t)
        for k, fault in flagged.items():
            if fault != "no_answer" and self.active[k]:
                self._fault(k, fault, t)
        return reading

    def _fault(self, k: int, fault: str, t: float) -> None:
        self.active = self.active.copy()  # the write path reads `active` without the lock: swap, not edit
        self.active[k] = False
        self._ids = [servo for servo, on in zip(self.map.ids, self.active) if on]
        self.on_fault(self, k, fault, t)

    def _log_bus_error(self, what: str, exc: Exception) -> None:
        skipped = _bus_faults.due(f"{self.name} {what} {type(exc).__name__}")
        if skipped is not None:
            again = f" ({skipped} more since the last report)" if skipped else ""
            log.error("%s: %s failed: %s%s", self.name, what, exc, again)

    def read_hz(self) -> float:
        """Reads per second over the last second (0 when none)."""
        now = time.monotonic()
        recent = [x for x in self._read_at if now - x <= 1.0]
        return float(len(recent)) if len(recent) > 1 else 0.0

    def readings(self) -> dict[str, dict[str, Any]]:
        """Per joint {commanded, measured, error, effort, saturated} (api_types.JointReading)."""
        with self._lock:
            commanded, measured, effort = self.commanded.copy(), self.measured.copy(), self.effort.copy()
        out: dict[str, dict[str, Any]] = {}
        for k, name in enumerate(self.map.names):
            c, m, e = float(commanded[k]), float(measured[k]), float(effort[k])
            if math.isnan(c):
                continue
            known = not math.isnan(m)
            out[name] = {
                "commanded": round(c, 6),
                "measured": round(m, 6) if known else None,
                "error": round(c - m, 6) if known else None,
                "effort": round(e, 4) if not math.isnan(e) else None,
                "saturated": bool(not math.isnan(e) and abs(e) >= SATURATED_EFFORT),
            }
        return out

    def status(self) -> dict[str, Any]:
        return {
            "driver": self.bus.kind,
            "port": self.bus.where,
            "joints": list(self.map.names),
            "writes": self.writes,
            "reads": self.reads,
            "read_hz": self.read_hz(),
            "missed_reads": self.missed,
            "dropped": self.dropped,
        }
