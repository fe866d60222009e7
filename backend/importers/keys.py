"""Key lists for clip tracks from source samples: constant, linear (optionally decimated), smooth
bezier keys through samples (cubic Hermite), bezier keys from glTF spline tangents; clamping.

Times are seconds, values the DoF's unit (rad, m or its own); a key is {"t", "v", "interp", ...}.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from backend.importers.mapping import SourceChannel
from backend.importers.rotations import hemisphere, quat_normalise, slerp

SAMPLED_DT = 0.05  # s: LINEAR keys at least this dense (20 Hz) are samples of a motion, not poses


def is_sampled(ch: SourceChannel) -> bool:
    """Frames of mocap, or keys an exporter sampled at a frame rate: a smooth curve goes through them."""
    if ch.decimate:
        return True
    t = np.asarray(ch.times, dtype=float)
    return ch.interp == "LINEAR" and len(t) >= 4 and float(np.median(np.diff(t))) <= SAMPLED_DT


def make_keys(
    ts: np.ndarray, vals: np.ndarray, mode: str, tol: float, dof, how: str, force: np.ndarray | None = None
) -> tuple[list[dict[str, Any]], str, int]:
    """Keys of one track: mode constant | linear | linear-decimated | smooth (Hermite keys through the
    samples) | a CSV --interp. Smooth keys are fitted to the samples clamped to the DoF's limits."""
    if mode == "smooth":
        n_cl = 0
        if dof.type.value == "continuous":
            clipped = np.clip(vals, dof.min, dof.max)
            n_cl = int(np.count_nonzero(clipped != vals))
            vals = clipped
        keys = hermite_keys(ts, vals, tol, force)
        within = f" within {tol:g}" if tol > 0 else ""
        return keys, how + f", smooth (bezier) keys through the samples{within}", n_cl
    if mode == "constant":
        return plain_keys(ts, vals, "constant"), how + ", constant keys", 0
    if mode == "linear-decimated" and tol > 0:
        t_keep, v_keep = decimate(ts, vals, tol)
        dropped = len(ts) - len(t_keep)
        return (
            plain_keys(t_keep, v_keep, "linear"),
            how + f", linear keys ({dropped} dropped within {tol:g})",
            0,
        )
    if mode in ("linear", "linear-decimated"):
        return plain_keys(ts, vals, "linear"), how + ", linear keys", 0
    return plain_keys(ts, vals, mode), how + f", {mode} keys", 0


def hermite_keys(
    times: np.ndarray, vals: np.ndarray, tol: float, force: np.ndarray | None = None
) -> list[dict[str, Any]]:
    """Samples -> bezier keys (free handles, a third of each segment) of the cubic Hermite curve through
    them with the samples' own slopes (central differences): smooth (continuous velocity) and exact at
    the kept samples. With tol > 0, samples that the curve between the kept ones reproduces within
    tol are dropped (greedy, like `decimate`); the samples at indices `force` are always kept."""
    t = np.asarray(times, dtype=float)
    v = np.asarray(vals, dtype=float)
    n = len(t)
    if n == 1:
        return plain_keys(t, v, "linear")
    m = np.gradient(v, t) if n > 2 else np.full(n, (v[1] - v[0]) / (t[1] - t[0]))
    if tol > 0 and n > 2:
        stops = sorted(set([n - 1] + ([] if force is None else [int(k) for k in force if 0 < k < n])))
        keep = [0]
        i = 0
        for stop in stops:
            while i < stop:
                j = i + 1
                while j + 1 <= stop and _hermite_ok(t, v, m, i, j + 1, tol):
                    j += 1
                keep.append(j)
                i = j
        idx = np.array(keep)
    else:
        idx = np.arange(n)
    return bezier_keys(t[idx], v[idx], m[idx], m[idx])


def _hermite_ok(t: np.ndarray, v: np.ndarray, m: np.ndarray, i: int, j: int, tol: float) -> bool:
    dt = t[j] - t[i]
    s = (t[i + 1 : j] - t[i]) / dt
    s2, s3 = s * s, s * s * s
    h = (
        (2 * s3 - 3 * s2 + 1) * v[i]
        + (s3 - 2 * s2 + s) * dt * m[i]
        + (-2 * s3 + 3 * s2) * v[j]
        + (s3 - s2) * dt * m[j]
    )
    return bool(np.all(np.abs(h - v[i + 1 : j]) <= tol))


def densify_slerp(
    times: np.ndarray,
    q: np.ndarray,
    values,
    tol: float,
    rate: float = 60.0,
    min_per_segment: int = 8,
    min_dt: float = 0.02,
) -> tuple[np.ndarray, np.ndarray, int]:
    """LINEAR rotation keys -> samples: the keys, plus dense slerp samples in the segments (longer
    than `min_dt`) where the angle of the slerp is not linear in time within tol/4."""
    q = hemisphere(quat_normalise(q))
    dt = np.diff(times)
    long = np.flatnonzero(dt > min_dt)
    if long.size == 0:
        return times, q, 0
    eps = max(tol / 4, 1e-6)
    v_keys = values(q)
    mids = slerp(q[long], q[long + 1], np.full(long.size, 0.5))
    v_mid = values(mids)
    # the keys' values are unwrapped along the keys; bring the midpoints to the same branch
    lin = 0.5 * (v_keys[long] + v_keys[long + 1])
    err = np.abs(((v_mid - lin) + math.pi) % (2 * math.pi) - math.pi).max(axis=1)
    seg = long[err > eps]
    if seg.size == 0:
        return times, q, 0
    ts, qs = [], []
    segset = set(seg.tolist())
    for k in range(len(times) - 1):
        if k in segset:
            m = max(min_per_segment, math.ceil(dt[k] * rate))
            u = np.arange(m) / m
            ts.append(times[k] + u * dt[k])
            qs.append(slerp(np.broadcast_to(q[k], (m, 4)), np.broadcast_to(q[k + 1], (m, 4)), u))
        else:
            ts.append(times[k : k + 1])
            qs.append(q[k : k + 1])
    ts.append(times[-1:])
    qs.append(q[-1:])
    return np.concatenate(ts), np.concatenate(qs), int(seg.size)


def plain_keys(times: np.ndarray, vals: np.ndarray, interp: str) -> list[dict[str, Any]]:
    return [{"t": round_key(t), "v": round_key(v), "interp": interp} for t, v in zip(times, vals)]


def round_key(x: float) -> float:
    """Key numbers rounded to 1e-10 (far below any joint's resolution) to keep the JSON readable."""
    return round(float(x), 10) + 0.0


def bezier_keys(
    times: np.ndarray, vals: np.ndarray, in_t: np.ndarray, out_t: np.ndarray
) -> list[dict[str, Any]]:
    """Cubic Hermite (glTF CUBICSPLINE) -> bezier keys with free handles, exactly the same curve."""
    keys = []
    n = len(times)
    for k in range(n):
        dt_prev = times[k] - times[k - 1] if k > 0 else 0.0
        dt_next = times[k + 1] - times[k] if k < n - 1 else 0.0
        keys.append(
            {
                "t": round_key(times[k]),
                "v": round_key(vals[k]),
                "interp": "bezier",
                "left_type": "free",
                "right_type": "free",
                "left": [round_key(-dt_prev / 3.0), round_key(-in_t[k] * dt_prev / 3.0)],
                "right": [round_key(dt_next / 3.0), round_key(out_t[k] * dt_next / 3.0)],
            }
        )
    return keys


def sample_hermite(
    times: np.ndarray,
    q: np.ndarray,
    in_t: np.ndarray,
    out_t: np.ndarray,
    rate: float = 60.0,
    min_per_segment: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """Dense samples of a glTF cubic spline of vectors (the unnormalised quaternion components)."""
    ts, qs = [], []
    for k in range(len(times) - 1):
        dt = times[k + 1] - times[k]
        m = max(min_per_segment, math.ceil(dt * rate))
        s = np.arange(m) / m
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        p = (
            h00[:, None] * q[k]
            + (h10 * dt)[:, None] * out_t[k]
            + h01[:, None] * q[k + 1]
            + (h11 * dt)[:, None] * in_t[k + 1]
        )
        ts.append(times[k] + s * dt)
        qs.append(p)
    ts.append(times[-1:])
    qs.append(q[-1:])
    return np.concatenate(ts), np.concatenate(qs)


def decimate(times: np.ndarray, vals: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Drop keys that linear interpolation between the kept keys reproduces within `tol` (greedy)."""
    times = np.asarray(times, dtype=float)
    vals = np.asarray(vals, dtype=float)
    n = len(times)
    if n <= 2:
        return times, vals
    keep = [0]
    i = 0
    while i < n - 1:
        j = i + 1
        while j + 1 < n:
            cand = j + 1
            mid = slice(i + 1, cand)
            u = (times[mid] - times[i]) / (times[cand] - times[i])
            err = np.abs(vals[i] + u * (vals[cand] - vals[i]) - vals[mid])
            if np.all(err <= tol):
                j = cand
            else:
                break
        keep.append(j)
        i = j
    idx = np.array(keep)
    return times[idx], vals[idx]


def clamp_keys(keys: list[dict[str, Any]], dof) -> int:
    if dof.type.value != "continuous":
        return 0
    n = 0
    for k in keys:
        v = k["v"]
        c = min(max(v, dof.min), dof.max)
        if c != v:
            n += 1
            k["v"] = c
            if "left" in k:  # flat at the limit
                k["left"][1] = 0.0
                k["right"][1] = 0.0
    return n
