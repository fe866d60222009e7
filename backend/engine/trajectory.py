"""The paper's *trajectory-helper*: where does a motion break the robot's limits, and its *ghost*.

`analyze` classifies every sample of a sampled trajectory per DoF from finite differences:
  0 ok (green), 1 velocity (orange), 2 acceleration (pink), 3 jerk (red), 4 position (outside limits).
When several limits are broken at once the most severe class wins: position > jerk > acceleration >
velocity (jerk is the most severe derivative because it is what a motor cannot follow at all).
`ghost` is the NMF-filtered version of the same trajectory: what the robot would really do.
The editor colours curves with `CLASS_COLOURS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.engine.nmf import MotionFilter

OK, VELOCITY, ACCELERATION, JERK, POSITION = 0, 1, 2, 3, 4
CLASS_NAMES = {OK: "ok", VELOCITY: "velocity", ACCELERATION: "acceleration", JERK: "jerk", POSITION: "position"}
CLASS_COLOURS = {"ok": "#3fbf5f", "velocity": "#ff9a2e", "acceleration": "#ff6fb5", "jerk": "#e5383b",
                 "position": "#9b5de5"}


def derivatives(positions: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Backward finite differences (T, n) of velocity, acceleration and jerk; the first samples,
    which lack history, are 0 (the trajectory is taken to start at rest)."""
    x = np.asarray(positions, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    vel = np.zeros_like(x)
    vel[1:] = np.diff(x, axis=0) * rate
    acc = np.zeros_like(x)
    acc[2:] = np.diff(vel[1:], axis=0) * rate
    jerk = np.zeros_like(x)
    jerk[3:] = np.diff(acc[2:], axis=0) * rate
    return vel, acc, jerk


@dataclass
class Analysis:
    """Per-sample classes (T, n) and a per-DoF summary."""

    classes: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    summary: list[dict[str, Any]] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return bool((self.classes == OK).all())

    def counts(self) -> dict[str, int]:
        return {name: int((self.classes == code).sum()) for code, name in CLASS_NAMES.items()}


def _limit(name: str, value: Any, n: int, allow_none: bool = False) -> np.ndarray | None:
    if value is None and allow_none:
        return None
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have one value per DoF ({n}), got shape {arr.shape}")
    return arr


def analyze(positions: np.ndarray, rate: float, vel_limit: Any, acc_limit: Any, jerk_limit: Any,
            pmin: Any = None, pmax: Any = None, tolerance: float = 1e-9) -> Analysis:
    """Classify every sample of `positions` (T,) or (T, n) sampled at `rate` Hz against the limits.

    Limits (units per s, s², s³) are scalars or per-DoF arrays, > 0 (inf: unlimited); `tolerance` is
    a relative slack for float round-off. Derivatives are backward differences with the trajectory
    taken to start at rest (see `derivatives`); the class of sample k says what reaching it needed.
    """
    x = np.asarray(positions, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ValueError(f"positions must have shape (T,) or (T, n), got {x.shape}")
    if not np.isfinite(x).all():
        raise ValueError("positions must be finite")
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive number of Hz, got {rate!r}")
    n = x.shape[1]
    for name, value in (("vel_limit", vel_limit), ("acc_limit", acc_limit), ("jerk_limit", jerk_limit)):
        arr = _limit(name, value, n)
        bad = np.flatnonzero(~(arr > 0))
        if bad.size:
            raise ValueError(f"{name} of DoF {int(bad[0])} must be > 0, got {float(arr[bad[0]])!r}")
    if (pmin is None) != (pmax is None):
        raise ValueError("pmin and pmax must be given together")
    vel, acc, jerk = derivatives(x, rate)
    slack = 1.0 + tolerance
    classes = np.zeros(x.shape, dtype=np.int8)
    classes[np.abs(vel) > np.asarray(vel_limit, dtype=float) * slack] = VELOCITY
    classes[np.abs(acc) > np.asarray(acc_limit, dtype=float) * slack] = ACCELERATION
    classes[np.abs(jerk) > np.asarray(jerk_limit, dtype=float) * slack] = JERK
    if pmin is not None and pmax is not None:
        span = np.abs(np.asarray(pmax, dtype=float) - np.asarray(pmin, dtype=float)) * tolerance
        outside = (x < np.asarray(pmin, dtype=float) - span) | (x > np.asarray(pmax, dtype=float) + span)
        classes[outside] = POSITION
    summary = []
    for i in range(x.shape[1]):
        c = classes[:, i]
        summary.append({
            "max_velocity": float(np.abs(vel[:, i]).max(initial=0.0)),
            "max_acceleration": float(np.abs(acc[:, i]).max(initial=0.0)),
            "max_jerk": float(np.abs(jerk[:, i]).max(initial=0.0)),
            **{name: int((c == code).sum()) for code, name in CLASS_NAMES.items()},
        })
    return Analysis(classes, vel, acc, jerk, summary)


def ghost(positions: np.ndarray, rate: float, preset: str | None = "D", order: int = 3, **filter_params: Any
          ) -> np.ndarray:
    """The NMF-filtered *ghost* of a trajectory (T,) or (T, n): what the robot would really do."""
    x = np.asarray(positions, dtype=float)
    one = x.ndim == 1
    x2 = x[:, None] if one else x
    if preset:
        f = MotionFilter.from_preset(preset, x2.shape[1], rate, order=order, **filter_params)
    else:
        f = MotionFilter(x2.shape[1], rate, order=order, **filter_params)
    out = f.run(x2).position
    return out[:, 0] if one else out


# --- motion-quality metrics (benchmarks, figures, tests) ----------------------------------------------


def overshoot(response: np.ndarray, start: float, target: float) -> float:
    """How far a step response went beyond its target, in the step's direction (>= 0)."""
    r = np.asarray(response, dtype=float)
    if target >= start:
        return float(max(0.0, r.max() - target))
    return float(max(0.0, target - r.min()))


def settle_time(response: np.ndarray, target: float, rate: float, tolerance: float) -> float:
    """Seconds from the first sample until the response enters and stays within `tolerance` of
    `target` (inf if it is still outside at the last sample)."""
    r = np.asarray(response, dtype=float)
    outside = np.flatnonzero(np.abs(r - target) > tolerance)
    if outside.size == 0:
        return 0.0
    last = int(outside[-1])
    return float("inf") if last == r.size - 1 else (last + 1) / rate


@dataclass
class StepMetrics:
    """Response to the steps of a stepped set-point signal (one DoF)."""

    overshoot: list[float]  # per step, beyond its target in the step's direction (units)
    settle: list[float]  # per step, s until within tolerance for good (inf: not before the next step)
    rms_error: float  # RMS of response - set-point over the whole signal (units)

    @property
    def max_overshoot(self) -> float:
        return max(self.overshoot, default=0.0)

    @property
    def settled(self) -> int:
        return sum(1 for s in self.settle if s != float("inf"))

    @property
    def mean_settle(self) -> float:
        """Mean settle time of the steps that settled (nan if none did)."""
        done = [s for s in self.settle if s != float("inf")]
        return float(np.mean(done)) if done else float("nan")


def step_metrics(setpoints: np.ndarray, response: np.ndarray, rate: float, tolerance: float = 0.05) -> StepMetrics:
    """Overshoot and settle time of every step of a stepped signal (T,), each judged until the next
    step; the settle band is `tolerance` times the step's size."""
    sp = np.asarray(setpoints, dtype=float)
    y = np.asarray(response, dtype=float)
    if sp.shape != y.shape or sp.ndim != 1:
        raise ValueError(f"setpoints and response must have the same shape (T,), got {sp.shape} and {y.shape}")
    starts = np.flatnonzero(np.diff(sp)) + 1
    bounds = np.r_[starts, sp.size]
    over, settle = [], []
    for k0, k1 in zip(bounds[:-1], bounds[1:]):
        before, target = sp[k0 - 1], sp[k0]
        seg = y[k0:k1]
        over.append(overshoot(seg, before, target))
        settle.append(settle_time(seg, target, rate, tolerance * abs(target - before)))
    return StepMetrics(over, settle, float(np.sqrt(np.mean((y - sp) ** 2))) if sp.size else 0.0)
