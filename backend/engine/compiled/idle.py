"""Compiled ticks of the idle sources: breathing, smooth noise, and the "rest plus an offset" frame that
weight shifts and blinks emit.

The numpy references are `Breathe.tick`, `Noise.tick`, `WeightShift.tick` and `Blink.tick`
(backend/engine/blocks/idle.py, blink.py): the same arithmetic per channel, in one call instead of
ten small numpy operations. Channels outside the block's `mask` get the rest pose; selected ones are
clipped to the position limits [lo, hi].
"""

from __future__ import annotations

import math

from numba import njit

from backend.engine.compiled import b1, b1_1, f8, f8_1, f8_2


@njit(cache=True)
def breathe_tick(
    phi, offset_cycles, amp_override, amp_values, scale, amplitude, inhale, rest, lo, hi, mask, out
):
    """The breath at cycle phase `phi` (cycles): `Breathe.wave` of each DoF's phase, times its amplitude."""
    for c in range(out.shape[0]):
        if not mask[c]:
            out[c] = rest[c]
            continue
        amp = amp_values[c] * scale if amp_override[c] else amplitude
        u = (phi + offset_cycles[c]) % 1.0
        v = 0.5 * u / inhale if u < inhale else 0.5 + 0.5 * (u - inhale) / (1.0 - inhale)
        out[c] = min(max(rest[c] + amp * -math.cos(2 * math.pi * v), lo[c]), hi[c])


BREATHE_SIG = (f8, f8_1, b1_1, f8_1, f8, f8, f8, f8_1, f8_1, f8_1, b1_1, f8_1)


@njit(cache=True)
def noise_tick(x, y, e, coef, step, smooth, gain, rest, lo, hi, mask, out):
    """One step of the two-stage Ornstein-Uhlenbeck wander (x, y advance in place when `step`) with the
    normal draws `e` (2, C) and the exact discretisation `coef` = (a, b, c, l11, l21, l22); the frame
    is rest + gain * y."""
    a, b, cc, l11, l21, l22 = coef[0], coef[1], coef[2], coef[3], coef[4], coef[5]
    for i in range(out.shape[0]):
        if step:
            x_new = a * x[i] + l11 * e[0, i]
            y[i] = cc * x[i] + b * y[i] + l21 * e[0, i] + l22 * e[1, i] if smooth else x_new
            x[i] = x_new
        out[i] = min(max(rest[i] + gain * y[i], lo[i]), hi[i]) if mask[i] else rest[i]


NOISE_SIG = (f8_1, f8_1, f8_2, f8_1, b1, b1, f8, f8_1, f8_1, f8_1, b1_1, f8_1)


@njit(cache=True)
def offset_tick(start, target, k, offset, rest, lo, hi, mask, out):
    """`offset` = start + k (target - start) (in place), and the frame rest + offset, clipped."""
    for c in range(out.shape[0]):
        offset[c] = start[c] + k * (target[c] - start[c])
        out[c] = min(max(rest[c] + offset[c], lo[c]), hi[c]) if mask[c] else rest[c]


OFFSET_SIG = (f8_1, f8_1, f8, f8_1, f8_1, f8_1, f8_1, b1_1, f8_1)
