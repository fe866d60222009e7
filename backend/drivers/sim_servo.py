"""A simulated servo per continuous DoF: a position loop with a bandwidth and speed/acceleration
saturation, so the effect of the motion filter is measurable without hardware.

Model (per DoF, stepped at the frame rate): desired velocity `v* = v_target + 2π·bandwidth·(target - q)`
(velocity feed-forward from the frame plus a proportional loop),
saturated to the DoF's velocity limit; the velocity changes at most by the acceleration limit per
second. It reports the tracking error (|target - q|, max and RMS) and the jerk of the servo's motion
(max and RMS: a bang-bang servo hits its maximum jerk on any target, the RMS tells how often).
"""

from __future__ import annotations

import threading

import numpy as np
from numba import njit

from backend.drivers.registry import DriverOption, positive_or_off
from backend.engine.compiled import default_compiled
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink


@njit(cache=True)
def _servo_step(
    position,
    velocity,
    idx,
    gain,
    vmax,
    amax,
    dt,
    has_samples,
    q,
    v,
    a,
    max_jerk,
    sq_jerk,
    max_error,
    sq_error,
):
    """`SimulatedServos.consume_reference` per DoF, in place (the same operations in the same order)."""
    for k in range(idx.shape[0]):
        target = position[idx[k]]
        want = min(max(velocity[idx[k]] + gain * (target - q[k]), -vmax[k]), vmax[k])
        dv = min(max(want - v[k], -(amax[k] * dt)), amax[k] * dt)
        a_new = dv / dt
        if has_samples:
            jerk = abs(a_new - a[k]) / dt
            max_jerk[k] = max(max_jerk[k], jerk)
            sq_jerk[k] += jerk * jerk
        a[k] = a_new
        v[k] = v[k] + dv
        q[k] = q[k] + v[k] * dt
        err = abs(target - q[k])
        max_error[k] = max(max_error[k], err)
        sq_error[k] += err * err


class SimulatedServos(Sink[AnimationFrame]):
    option = DriverOption(
        "sim-servo",
        metavar="HZ",
        parse=positive_or_off,
        default=8.0,
        help="bandwidth of the simulated servos whose tracking error /api/status reports (0 = off)",
    )

    def __init__(self, embodiment: Embodiment, bandwidth_hz: float = 8.0, decimate: int = 1):
        if not bandwidth_hz > 0:
            raise ValueError(f"bandwidth_hz must be > 0, got {bandwidth_hz}")
        self.emb = embodiment
        self.idx = np.flatnonzero(embodiment.continuous_mask)
        self.gain = 2 * np.pi * bandwidth_hz
        self.vmax = embodiment.vel_limit[self.idx]
        self.amax = embodiment.acc_limit[self.idx]
        self.q = embodiment.rest[self.idx].copy()
        self.v = np.zeros(self.idx.size)
        self.a = np.zeros(self.idx.size)
        self._lock = threading.Lock()
        self.samples = 0
        self.max_error = np.zeros(self.idx.size)
        self._sq_error = np.zeros(self.idx.size)
        self.max_jerk = np.zeros(self.idx.size)
        self._sq_jerk = np.zeros(self.idx.size)
        self._last_t: float | None = None
        self._commanded: np.ndarray | None = None  # the last frame's targets (DoF units)
        self._idx64 = self.idx.astype(np.int64)
        #: Step with the compiled kernel (False: the numpy reference, `consume_reference`).
        self.compiled = default_compiled()
        # A simulation wants every frame: a deep queue (live it keeps up easily; headless it catches up).
        # It wakes 100 times a second, whatever the clock's rate (`batch`).
        super().__init__("sim-servo", max_queue=4096, decimate=decimate, batch=0.01)

    @classmethod
    def from_option(cls, embodiment: Embodiment, bandwidth_hz: float) -> SimulatedServos:
        return cls(embodiment, bandwidth_hz=bandwidth_hz)

    def consume(self, frame: AnimationFrame) -> None:
        # Integrate over the real time since the last frame this servo saw (frames may be dropped).
        dt = frame.dt if self._last_t is None else frame.t - self._last_t
        self._last_t = frame.t
        self._commanded = frame.position[self.idx]  # a new array (fancy indexing): safe to keep
        if dt <= 0:
            return
        if (
            self.compiled
            and frame.position.dtype == np.float64
            and frame.velocity.dtype == np.float64
            and frame.position.shape == frame.velocity.shape == self.emb.rest.shape
            and frame.position.flags.c_contiguous
            and frame.velocity.flags.c_contiguous
        ):
            with self._lock:
                _servo_step(
                    frame.position,
                    frame.velocity,
                    self._idx64,
                    self.gain,
                    self.vmax,
                    self.amax,
                    float(dt),
                    self.samples > 0,
                    self.q,
                    self.v,
                    self.a,
                    self.max_jerk,
                    self._sq_jerk,
                    self.max_error,
                    self._sq_error,
                )
                self.samples += 1
            return
        self.consume_reference(frame, dt)

    def consume_reference(self, frame: AnimationFrame, dt: float) -> None:
        """The numpy definition of one servo step over `dt` seconds (`_servo_step` compiles it)."""
        target = frame.position[self.idx]
        with self._lock:
            want = np.clip(frame.velocity[self.idx] + self.gain * (target - self.q), -self.vmax, self.vmax)
            dv = np.clip(want - self.v, -self.amax * dt, self.amax * dt)
            a_new = dv / dt
            if self.samples:
                jerk = np.abs(a_new - self.a) / dt
                self.max_jerk = np.maximum(self.max_jerk, jerk)
                self._sq_jerk += jerk**2
            self.a = a_new
            self.v = self.v + dv
            self.q = self.q + self.v * dt
            err = np.abs(target - self.q)
            self.max_error = np.maximum(self.max_error, err)
            self._sq_error += err**2
            self.samples += 1

    def measured(self) -> dict[str, dict[str, float | bool | None]]:
        """Per DoF where the servo is now: {commanded, measured, error (DoF units), effort (None: a
        simulated servo has no torque), saturated (moving at its velocity limit)}. The shape every
        driver that reads its motors reports (get_status `measured`)."""
        with self._lock:
            commanded = self._commanded
            if commanded is None:
                return {}
            q, v = self.q.copy(), self.v.copy()
        saturated = np.abs(v) >= self.vmax * (1 - 1e-9)
        return {
            self.emb.channel_names[c]: {
                "commanded": round(float(commanded[k]), 6),
                "measured": round(float(q[k]), 6),
                "error": round(float(commanded[k] - q[k]), 6),
                "effort": None,
                "saturated": bool(saturated[k]),
            }
            for k, c in enumerate(self.idx)
        }

    def report(self) -> dict[str, dict[str, float]]:
        """Per DoF: max and RMS tracking error (DoF units) and max jerk of the servo (units/s³)."""
        with self._lock:
            n = max(self.samples, 1)
            rms = np.sqrt(self._sq_error / n)
            rms_jerk = np.sqrt(self._sq_jerk / n)
            return {
                self.emb.channel_names[c]: {
                    "max_error": float(self.max_error[k]),
                    "rms_error": float(rms[k]),
                    "max_jerk": float(self.max_jerk[k]),
                    "rms_jerk": float(rms_jerk[k]),
                }
                for k, c in enumerate(self.idx)
            }

    def stats(self) -> dict:
        base = super().stats()
        rep = self.report()
        base["worst_rms_error"] = max((r["rms_error"] for r in rep.values()), default=0.0)
        base["worst_jerk"] = max((r["max_jerk"] for r in rep.values()), default=0.0)
        return base
