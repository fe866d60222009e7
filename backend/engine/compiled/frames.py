"""Compiled ticks of the small frame operators that every program runs, and the engine's derivatives.

Each is the same arithmetic as its numpy reference, channel by channel, in one call (a few numpy
calls with scalar arguments cost more than the whole loop):
- `gain_offset_tick`: `GainOffset.transform` (backend/engine/blocks/core.py);
- `limiter_tick`: `SafetyLimiter.tick` (position clip and velocity slew; not the engine's safety net,
  which stays `backend.engine.safety.SafetyNet`);
- `hold_tick`: `Output.tick` (hold the channels a frame does not set, clip to the limits);
- `filter_tick`: `_FilterBlock.tick` around one step of the NMF's own compiled kernel;
- `derivatives`: the engine's finite differences of the emitted positions (`Engine.tick`).
"""

from __future__ import annotations

import math

from numba import njit

from backend.engine.compiled import b1, b1_1, f8, f8_1, f8_2, i8, i8_1
from backend.engine.nmf.kernels import _step_one_pass, _step_passes
from backend.engine.nmf.params import _X


@njit(cache=True)
def gain_offset_tick(values, rest, sel, gain, offset, out):
    """rest + gain (value - rest) + offset on the selected channels; the others pass through."""
    for c in range(out.shape[0]):
        out[c] = rest[c] + gain * (values[c] - rest[c]) + offset if sel[c] else values[c]


GAIN_OFFSET_SIG = (f8_1, f8_1, b1_1, f8, f8, f8_1)


@njit(cache=True)
def limiter_tick(values, mask, has_frame, last, lo, hi, vmax, dt):
    """Where the frame sets a channel, move `last` (in place) toward it, clipped to [lo, hi], by at most
    vmax * dt; elsewhere toward the held value (which stays, unless it is outside [lo, hi])."""
    for c in range(last.shape[0]):
        target = values[c] if (has_frame and mask[c]) else last[c]
        target = min(max(target, lo[c]), hi[c])
        step = vmax[c] * dt
        last[c] = last[c] + min(max(target - last[c], -step), step)


LIMITER_SIG = (f8_1, b1_1, b1, f8_1, f8_1, f8_1, f8_1, f8)


@njit(cache=True)
def hold_tick(values, mask, held, lo, hi):
    """Write the frame's set channels into `held` and clip every channel to [lo, hi] (in place)."""
    for c in range(held.shape[0]):
        v = values[c] if mask[c] else held[c]
        held[c] = min(max(v, lo[c]), hi[c])


HOLD_SIG = (f8_1, b1_1, f8_1, f8_1, f8_1)


@njit(cache=True)
def filter_tick(values, mask, has_frame, idx, sp, buf, cfg, one_pass, rest, out, out_mask):
    """One NMF step on the channels `idx`: set-points from the frame (NaN = hold where it sets nothing,
    or when there is no frame), the filtered positions into `out` over the frame (or the rest pose)."""
    for j in range(idx.shape[0]):
        c = idx[j]
        sp[j] = values[c] if (has_frame and mask[c]) else math.nan
    if one_pass:
        _step_one_pass(sp, buf, cfg)
    else:
        _step_passes(sp, buf, cfg)
    for c in range(out.shape[0]):
        out[c] = values[c] if has_frame else rest[c]
        out_mask[c] = mask[c] if has_frame else False
    for j in range(idx.shape[0]):
        out[idx[j]] = buf[_X, j]
        out_mask[idx[j]] = True


FILTER_SIG = (f8_1, b1_1, b1, i8_1, f8_1, f8_2, f8_1, b1, f8_1, f8_1, b1_1)


@njit(cache=True)
def derivatives(pos, last_pos, last_vel, last_acc, dt, seq, vel, acc, jerk):
    """Finite differences of the emitted positions (per s, s², s³), zero until there is history."""
    for c in range(pos.shape[0]):
        v = (pos[c] - last_pos[c]) / dt if seq > 0 else 0.0
        a = (v - last_vel[c]) / dt if seq > 1 else 0.0
        vel[c] = v
        acc[c] = a
        jerk[c] = (a - last_acc[c]) / dt if seq > 2 else 0.0


DERIVATIVES_SIG = (f8_1, f8_1, f8_1, f8_1, f8, i8, f8_1, f8_1, f8_1)
