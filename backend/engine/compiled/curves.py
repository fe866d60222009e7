"""Compiled evaluation of a `CurveSet` (backend/engine/curves.py): every curve of a clip at one time.

The numpy reference is `CurveSet.evaluate` with `ease` and the bracketed Newton solve of `_bezier`;
this kernel walks the curves one by one with the same formulas (as numpy operations on a handful of
curves, the Bezier's 12 Newton steps are mostly numpy's per-call overhead, many times the compiled
walk; figures in benchmarks/RESULTS.md). Interpolation codes are the
indices of `curves.INTERPS`; easing modes 0 in, 1 out, 2 in_out.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba import types as nt

from backend.engine.compiled import b1, b1_1, f8, f8_1, f8_2, f8_3, i8_1

_SINE, _QUAD, _CUBIC, _QUART, _QUINT, _EXPO, _CIRC, _BACK, _ELASTIC, _BOUNCE = range(3, 13)


@njit(cache=True)
def _bounce_out(u):
    n, d = 7.5625, 2.75
    if u < 1 / d:
        return n * u * u
    if u < 2 / d:
        x = u - 1.5 / d
        return n * (x * x) + 0.75
    if u < 2.5 / d:
        x = u - 2.25 / d
        return n * (x * x) + 0.9375
    x = u - 2.625 / d
    return n * (x * x) + 0.984375


@njit(cache=True, error_model="numpy")
def _ease_in(code, u):
    """`curves._ease_in` for one u (powers through libm's pow, as numpy's do)."""
    if code == _SINE:
        return 1.0 - math.cos(u * math.pi / 2)
    if code == _QUAD:
        return u * u
    if code == _CUBIC:
        return math.pow(u, 3.0)
    if code == _QUART:
        return math.pow(u, 4.0)
    if code == _QUINT:
        return math.pow(u, 5.0)
    if code == _EXPO:
        if u <= 0.0:
            return 0.0
        return math.pow(2.0, 10.0 * min(u, 1.0) - 10.0) - (1 - u) * math.pow(2.0, -10.0)
    if code == _CIRC:
        return 1.0 - math.sqrt(max(0.0, 1.0 - u * u))
    if code == _BACK:
        c1 = 1.70158
        return (c1 + 1) * math.pow(u, 3.0) - c1 * (u * u)
    if code == _ELASTIC:
        if u <= 0.0:
            return 0.0
        if u >= 1.0:
            return 1.0
        return -math.pow(2.0, 10 * u - 10) * math.sin((u * 10 - 10.75) * (2 * math.pi / 3))
    return 1.0 - _bounce_out(1.0 - u)  # bounce


@njit(cache=True)
def _ease(code, mode, u):
    """`curves.ease`: in (0), out (1) or in_out (2)."""
    u = min(max(u, 0.0), 1.0)
    if mode == 0:
        return _ease_in(code, u)
    if mode == 1:
        return 1.0 - _ease_in(code, 1.0 - u)
    if u < 0.5:
        return 0.5 * _ease_in(code, 2 * u)
    return 1.0 - 0.5 * _ease_in(code, 2 - 2 * u)


@njit(cache=True, error_model="numpy")
def _bezier(x0, y0, x1, y1, x2, y2, x3, y3, t):
    """`CurveSet._bezier` for one segment: x(u) = t by bracketed Newton, then y(u)."""
    lo, hi = 0.0, 1.0
    u = (t - x0) / (x3 - x0)
    for _ in range(12):
        a = 1.0 - u
        x = a * a * a * x0 + 3 * a * a * u * x1 + 3 * a * u * u * x2 + u * u * u * x3
        f = x - t
        if f < 0:
            lo = u
        if f > 0:
            hi = u
        dx = 3 * a * a * (x1 - x0) + 6 * a * u * (x2 - x1) + 3 * u * u * (x3 - x2)
        step = u - f / dx
        u = step if (math.isfinite(step) and step >= lo and step <= hi) else 0.5 * (lo + hi)
    a = 1.0 - u
    return a * a * a * y0 + 3 * a * a * u * y1 + 3 * a * u * u * y2 + u * u * u * y3


@njit(cache=True, error_model="numpy")
def evaluate(keys_t, keys_v, h_right, h_left, code, mode, n_keys, t, out):
    """Every curve's value at time `t` into `out` (see `CurveSet.evaluate`)."""
    for i in range(out.shape[0]):
        last = n_keys[i] - 1
        count = 0
        for j in range(keys_t.shape[1]):
            if keys_t[i, j] <= t:
                count += 1
        idx = min(count - 1, last)
        if idx < 0:  # before the first key
            out[i] = keys_v[i, 0]
            continue
        if idx >= last:  # at or after the last key
            out[i] = keys_v[i, last]
            continue
        nxt = idx + 1
        t0, t1 = keys_t[i, idx], keys_t[i, nxt]
        v0, v1 = keys_v[i, idx], keys_v[i, nxt]
        u = min(max((t - t0) / (t1 - t0), 0.0), 1.0)
        c = code[i, idx]
        if c == 0:  # constant
            out[i] = v0
        elif c == 1:  # linear
            out[i] = v0 + u * (v1 - v0)
        elif c == 2:  # bezier
            out[i] = _bezier(
                t0,
                v0,
                h_right[i, idx, 0],
                h_right[i, idx, 1],
                h_left[i, nxt, 0],
                h_left[i, nxt, 1],
                t1,
                v1,
                t,
            )
        else:
            out[i] = v0 + _ease(c, mode[i, idx], u) * (v1 - v0)


EVALUATE_SIG = (f8_2, f8_2, f8_3, f8_3, nt.int64[:, ::1], nt.int64[:, ::1], i8_1, f8, f8_1)


@njit(cache=True, error_model="numpy")
def clip_tick(
    keys_t,
    keys_v,
    h_right,
    h_left,
    code,
    mode,
    n_keys,
    t,
    channels,
    relative,
    enum,
    rest,
    values,
    xfade,
    k,
    from_values,
    old_mask,
    mask,
    rel,
    weight,
    out,
):
    """A playing clip's frame (see `ClipPlayer.tick` and `CompiledClip.sample`): the curves at clip time
    `t` into the shown pose `values` (C,) at their `channels` (offsets from `rest` where `relative`,
    option indices rounded where `enum`); while `xfade`, `values` crossfades from `from_values` by `k`
    (channels only the old clip set keep their old value); `out` (C,) receives `values`, faded toward
    `rest` by `weight` when `rel` (a relative clip)."""
    vals = np.empty(channels.shape[0])
    clip_frame(keys_t, keys_v, h_right, h_left, code, mode, n_keys, t, channels, relative, enum, rest, values,
               xfade, k, from_values, old_mask, mask, rel, weight, out, vals)  # fmt: skip


@njit(cache=True, error_model="numpy")
def clip_frame(
    keys_t, keys_v, h_right, h_left, code, mode, n_keys, t, channels, relative, enum, rest, values, xfade, k,
    from_values, old_mask, mask, rel, weight, out, vals,
):  # fmt: skip
    """`clip_tick` with the curves' values evaluated into `vals` (K,), a buffer of the caller's (the
    compiled program core's: its steady tick allocates nothing)."""
    evaluate(keys_t, keys_v, h_right, h_left, code, mode, n_keys, t, vals)
    for i in range(channels.shape[0]):
        v = vals[i]
        if relative[i]:
            v = v + rest[channels[i]]
        if enum[i]:
            v = np.rint(v)
        values[channels[i]] = v
    if xfade:
        for c in range(values.shape[0]):
            if old_mask[c] and not mask[c]:
                values[c] = from_values[c]
            else:
                values[c] = from_values[c] + k * (values[c] - from_values[c])
    for c in range(values.shape[0]):
        out[c] = rest[c] + weight * (values[c] - rest[c]) if rel else values[c]


CLIP_SIG = (
    f8_2,
    f8_2,
    f8_3,
    f8_3,
    nt.int64[:, ::1],
    nt.int64[:, ::1],
    i8_1,
    f8,
    i8_1,
    b1_1,
    b1_1,
    f8_1,
    f8_1,
    b1,
    f8,
    f8_1,
    b1_1,
    b1_1,
    b1,
    f8,
    f8_1,
)
