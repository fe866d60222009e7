"""A playing clip's clock in compiled code: the compiled program core's step of a clip player on a
steady tick (backend/engine/core/clip_ops.py), the arithmetic of `ClipPlayer.tick`'s `_advance` and
`_tick_compiled`, which the block's own tick keeps for every other tick.

`clock` is the block's `State.clock` (pos, play_t, direction, env, env_target, xfade_t, xfade, fade_in,
fade_out, done); `S[s..]` the op's scalars (vm.py's CLIP).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.compiled.signals import py_max, py_min

ONCE, LOOP, PING_PONG = 0.0, 1.0, 2.0  # the play mode's code (vm.CLIP's scalar `mode`)
MODE_CODES = {"once": ONCE, "loop": LOOP, "ping_pong": PING_PONG}


@njit(cache=True)
def smooth(x):
    """clip_player.smooth_step: smoothstep of x clamped to [0, 1]."""
    x = py_min(py_max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


@njit(cache=True)
def clip_clock(clock, S, s, dt, event_times, warp_play, warp_clip):
    """Step the clock of the clip playing one tick of `dt` s: the playhead at the speed `S[s]` (or along
    the anchor warp when `S[s + 3]`), the crossfade (its factor into `S[s + 12]`, whether it runs into
    `S[s + 11]`) and the envelope (its weight into `S[s + 9]`). False, having changed nothing, when the
    tick is Python's: the clip ends, loops or bounces, the playhead passes an event, or the fade-out of
    a finished clip ends (each has notes, events or a next clip)."""
    pos, play_t, env = clock[0], clock[1], clock[3]
    done = clock[9] > 0.5
    if not done:
        mode = S[s + 2]
        play_t = play_t + dt
        if S[s + 3] > 0.5 and mode == ONCE:
            new = np.interp(play_t, warp_play, warp_clip)
        else:
            new = pos + clock[2] * S[s] * dt
        if new >= S[s + 1] or (mode == PING_PONG and new <= 0.0):
            return False
        if clock[2] > 0.0:  # events fire going forward (`_events_between`: t0 < t <= t1)
            t0 = pos if pos > 0.0 else -1e-12
            for t in event_times:
                if t0 < t <= new:
                    return False
        pos = new
    target = clock[4]
    if env < target:  # `_advance_envelope`
        rate = 1.0 / clock[7] if clock[7] > 0 else math.inf
        env = py_min(target, env + rate * dt)
    elif env > target:
        rate = 1.0 / clock[8] if clock[8] > 0 else math.inf
        env = py_max(target, env - rate * dt)
    if done and env <= 0.0:
        return False
    clock[0], clock[1], clock[3] = pos, play_t, env
    xfade = clock[5] < clock[6]
    k = 0.0
    if xfade:
        clock[5] = clock[5] + dt
        k = smooth(clock[5] / clock[6])
    S[s + 11] = 1.0 if xfade else 0.0
    S[s + 12] = k
    S[s + 9] = smooth(env)
    return True
