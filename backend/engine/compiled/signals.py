"""Compiled ticks of the signal blocks the program core runs as ops: the emotion mapper and scalar math,
and the drive that carries a compiled signal into a parameter of a compiled block.

The numpy (plain Python) references are `Emotion.tick`, `Math.tick` and `DrivenParam.resolve`
(backend/engine/blocks/signals.py, driven.py): the same float arithmetic in the same order, so both
give the same numbers. Python's `min`/`max` keep their first argument unless the second is strictly
smaller/greater (a NaN or a zero's sign passes as they pass it); `py_min`/`py_max` do the same.
"""

from __future__ import annotations

import math

from numba import njit

#: Math op codes (the `op` parameter's order in `MathOp`).
MATH_OPS = ("add", "subtract", "multiply", "divide", "min", "max", "map_range", "clamp", "abs", "smoothstep")
ADD, SUBTRACT, MULTIPLY, DIVIDE, MIN, MAX, MAP_RANGE, CLAMP, ABS, SMOOTHSTEP = range(len(MATH_OPS))

#: Emotion.SETTLE (signals.py): how near the smoothing lands on its target.
EMOTION_SETTLE = 1e-6


@njit(cache=True)
def py_max(x, y):
    """Python's max(x, y) of two floats."""
    return y if y > x else x


@njit(cache=True)
def py_min(x, y):
    """Python's min(x, y) of two floats."""
    return y if y < x else x


@njit(cache=True)
def same_float(x, y):
    """Whether two floats are the same number, a zero's sign included (a NaN is never the same)."""
    return x == y and (x != 0.0 or math.copysign(1.0, x) == math.copysign(1.0, y))


@njit(cache=True)
def drive(S, table):
    """Each row of `table` (src slot, dst slot, lo, hi, fallback) sets `S[dst]` to `S[src]` clamped to
    [lo, hi] when it is finite, else to the fallback: `DrivenParam.resolve` of a wired float."""
    for j in range(table.shape[0]):
        x = S[int(table[j, 0])]
        S[int(table[j, 1])] = py_min(py_max(x, table[j, 2]), table[j, 3]) if math.isfinite(x) else table[j, 4]


@njit(cache=True)
def math_value(code, a, b, in_min, in_max, out_min, out_max, clamped, lo, hi):
    """`Math.compute(a, b)` (NaN where Python's would be NaN)."""
    if code == ADD:
        return a + b
    if code == SUBTRACT:
        return a - b
    if code == MULTIPLY:
        return a * b
    if code == DIVIDE:
        return a / b if b != 0.0 else math.nan
    if code == MIN:
        return py_min(a, b)
    if code == MAX:
        return py_max(a, b)
    if code == ABS:
        return abs(a)
    if code == CLAMP:
        return py_min(py_max(a, lo), hi)
    u = (a - in_min) / (in_max - in_min)
    if code == SMOOTHSTEP:
        u = py_min(py_max(u, 0.0), 1.0)
        return u * u * (3.0 - 2.0 * u)
    if clamped:
        u = py_min(py_max(u, 0.0), 1.0)
    return out_min + u * (out_max - out_min)


@njit(cache=True)
def _landed(value, target):
    return target if abs(target - value) <= EMOTION_SETTLE else value


@njit(cache=True)
def emotion_tick(x, tv, ta, k, c, postures, out):
    """One `Emotion.tick`: the state `x` = (valence, arousal, primed, posture index or -1) steps towards
    the targets (tv, ta) with the smoothing coefficient `k`; `c` = (speed_min, speed_max, amplitude_min,
    amplitude_max, valence_amplitude, droop, arousal_lift, hysteresis); `postures` (n, 2) their (valence,
    arousal) in the parameter's order. Writes (speed, amplitude, posture_offset, valence, arousal, posture
    index) into `out`."""
    if x[2] < 0.5:
        v, a = tv, ta
        x[2] = 1.0
    else:
        v = _landed(x[0] + k * (tv - x[0]), tv)
        a = _landed(x[1] + k * (ta - x[1]), ta)
    x[0], x[1] = v, a
    current = int(x[3])
    best, best_d, current_d = 0, math.inf, math.nan
    for j in range(postures.shape[0]):
        d = math.hypot(v - postures[j, 0], a - postures[j, 1])
        if d < best_d:  # the first of equally near postures, as min() picks it
            best, best_d = j, d
        if j == current:
            current_d = d
    if not (current >= 0 and best_d > current_d - c[7]):
        x[3] = best
    out[0] = 1.0 + a * ((c[1] - 1.0) if a > 0 else (1.0 - c[0]))
    amp_a = 1.0 + a * ((c[3] - 1.0) if a > 0 else (1.0 - c[2]))
    out[1] = amp_a + c[4] * abs(v)
    out[2] = -v * c[5] - py_max(a, 0.0) * c[6]
    out[3], out[4], out[5] = v, a, x[3]
