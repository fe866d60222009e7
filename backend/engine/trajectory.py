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

from backend.engine.nmf import PRESETS, MotionFilter

OK, VELOCITY, ACCELERATION, JERK, POSITION = 0, 1, 2, 3, 4
CLASS_NAMES = {
    OK: "ok",
    VELOCITY: "velocity",
    ACCELERATION: "acceleration",
    JERK: "jerk",
    POSITION: "position",
}
CLASS_COLOURS = {
    "ok": "#3fbf5f",
    "velocity": "#ff9a2e",
    "acceleration": "#ff6fb5",
    "jerk": "#e5383b",
    "position": "#9b5de5",
}


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


def _limit(name: str, value: Any, n: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have one value per DoF ({n}), got shape {arr.shape}")
    return arr


def analyze(
    positions: np.ndarray,
    rate: float,
    vel_limit: Any,
    acc_limit: Any,
    jerk_limit: Any,
    pmin: Any = None,
    pmax: Any = None,
    tolerance: float = 1e-9,
) -> Analysis:
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
        summary.append(
            {
                "max_velocity": float(np.abs(vel[:, i]).max(initial=0.0)),
                "max_acceleration": float(np.abs(acc[:, i]).max(initial=0.0)),
                "max_jerk": float(np.abs(jerk[:, i]).max(initial=0.0)),
                **{name: int((c == code).sum()) for code, name in CLASS_NAMES.items()},
            }
        )
    return Analysis(classes, vel, acc, jerk, summary)


def ghost(
    positions: np.ndarray, rate: float, preset: str | None = "D", order: int = 3, **filter_params: Any
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


def step_metrics(
    setpoints: np.ndarray, response: np.ndarray, rate: float, tolerance: float = 0.05
) -> StepMetrics:
    """Overshoot and settle time of every step of a stepped signal (T,), each judged until the next
    step; the settle band is `tolerance` times the step's size."""
    sp = np.asarray(setpoints, dtype=float)
    y = np.asarray(response, dtype=float)
    if sp.shape != y.shape or sp.ndim != 1:
        raise ValueError(
            f"setpoints and response must have the same shape (T,), got {sp.shape} and {y.shape}"
        )
    starts = np.flatnonzero(np.diff(sp)) + 1
    bounds = np.r_[starts, sp.size]
    over, settle = [], []
    for k0, k1 in zip(bounds[:-1], bounds[1:]):
        before, target = float(sp[k0 - 1]), float(sp[k0])
        seg = y[k0:k1]
        over.append(overshoot(seg, before, target))
        settle.append(settle_time(seg, target, rate, tolerance * abs(target - before)))
    return StepMetrics(over, settle, float(np.sqrt(np.mean((y - sp) ** 2))) if sp.size else 0.0)


# --- what a trajectory needs to fit the limits (the importer's report) --------------------------------


def limit_counts(
    positions: np.ndarray,
    rate: float,
    vel_limit: Any,
    acc_limit: Any,
    jerk_limit: Any,
    tolerance: float = 1e-9,
) -> list[dict[str, Any]]:
    """Per DoF of `positions` (T,) or (T, n): how many samples are over the velocity, the acceleration
    and the jerk limit, each counted on its own (a sample may be over several), and the peaks.
    Same finite differences and slack as `analyze`."""
    x = np.asarray(positions, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[1]
    lims = [
        _limit(name, value, n)
        for name, value in (("vel_limit", vel_limit), ("acc_limit", acc_limit), ("jerk_limit", jerk_limit))
    ]
    derivs = derivatives(x, rate)
    slack = 1.0 + tolerance
    out = []
    for i in range(n):
        row: dict[str, Any] = {"samples": int(x.shape[0])}
        for name, d, lim in zip(("velocity", "acceleration", "jerk"), derivs, lims):
            peak = float(np.abs(d[:, i]).max(initial=0.0))
            row[name] = int((np.abs(d[:, i]) > lim[i] * slack).sum())
            row[f"max_{name}"] = peak
            row[f"{name}_limit"] = float(lim[i])
        out.append(row)
    return out


def time_scale_to_fit(
    sample: Any,
    duration: float,
    rate: float,
    vel_limit: Any,
    acc_limit: Any,
    jerk_limit: Any,
    max_scale: float = 20.0,
    precision: float = 0.01,
) -> float | None:
    """The smallest uniform slow-down factor s >= 1 (within `precision`, relative) such that the
    trajectory played s times slower and sampled at `rate` is within every velocity, acceleration
    and jerk limit; None if even `max_scale` is not enough.

    `sample(t)` returns the positions (len(t), n) at trajectory times `t` (s, in [0, duration])."""

    def fits(s: float) -> bool:
        t = np.arange(int(np.floor(duration * s * rate + 1e-9)) + 1) / rate / s
        if t.size < 2:
            t = np.array([0.0, duration])
        x = np.asarray(sample(np.minimum(t, duration)), dtype=float)
        counts = limit_counts(x, rate, vel_limit, acc_limit, jerk_limit)
        return all(c["velocity"] == 0 and c["acceleration"] == 0 and c["jerk"] == 0 for c in counts)

    if fits(1.0):
        return 1.0
    if max_scale <= 1.0:
        return None
    lo, hi = 1.0, min(2.0, max_scale)
    while not fits(hi):
        if hi >= max_scale:
            return None
        lo, hi = hi, min(hi * 2.0, max_scale)
    while hi / lo > 1.0 + precision:
        mid = float(np.sqrt(lo * hi))
        if fits(mid):
            hi = mid
        else:
            lo = mid
    return hi


def preset_fit(
    positions: np.ndarray,
    rate: float,
    vel_limit: Any,
    acc_limit: Any,
    jerk_limit: Any,
    pmin: Any = None,
    pmax: Any = None,
    presets: Any = None,
    limiter: str = "tanh",
) -> list[dict[str, Any]]:
    """How well each NMF preset keeps the shape of a trajectory (T,) or (T, n) under the robot's
    limits (as the stage-2 filter applies them: the tanh limiter gets 2 x the velocity bound), best
    first: {"preset", "rms", "max" (deviation of the filtered ghost from the trajectory, over all
    samples and DoFs), "ghost_ok" (the ghost itself is within the limits)}."""

    x = np.asarray(positions, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[1]
    vel = _limit("vel_limit", vel_limit, n)
    acc = _limit("acc_limit", acc_limit, n)
    jerk = _limit("jerk_limit", jerk_limit, n)
    lo, hi = (None, None) if pmin is None else (_limit("pmin", pmin, n), _limit("pmax", pmax, n))
    out = []
    for name in presets or list(PRESETS):
        p = PRESETS[name]
        f = MotionFilter(
            n,
            rate,
            order=3,
            sigma=p.sigma,
            rho=p.rho,
            bypass=p.bypass,
            limiter=limiter,
            vel_limit=vel * (2.0 if limiter == "tanh" else 1.0),
            acc_limit=acc,
            jerk_limit=jerk,
            x0=x[0],
            pmin=lo,
            pmax=hi,
        )
        g = f.run(x).position
        err = np.abs(g - x)
        counts = limit_counts(g, rate, vel, acc, jerk, tolerance=1e-3)
        out.append(
            {
                "preset": name,
                "meaning": p.meaning,
                "rms": float(np.sqrt(np.mean(err**2))),
                "max": float(err.max(initial=0.0)),
                "ghost_ok": all(
                    c["velocity"] == 0 and c["acceleration"] == 0 and c["jerk"] == 0 for c in counts
                ),
            }
        )
    out.sort(key=lambda r: r["rms"])
    return out
