"""The compiled program core's kernel: one call runs a run of compiled steps over the frame arena.

`run_ops(ops, k0, k1, ...)` executes rows k0..k1-1 of the op table, each one block's whole tick,
calling the same per-block kernels the blocks' own compiled ticks call (`backend.engine.compiled`), so
both paths compute the same numbers. It is compiled once for one signature (and cached on disk by
numba): a new program never compiles anything, it only fills a new op table.

The op table (`ops`, int64, one row per compiled step): column 0 the op code, 1 the arena row it
writes, 2 the arena row of its frame input (-1: none), 3 the first of its scalar slots in `S`, and
4.. rows of `refs`, the arrays the op reads and writes in place (each op's comment says which). The
first rows of `refs` are the arena's arrays and the robot's rest pose, limits and enum mask.

`refs` rows are (address, shape0, shape1, shape2) of arrays the blocks own: their state and their derived
constants, so the kernel and the blocks' own ticks step the same memory. The core that fills the table
(backend/engine/core/program.py) keeps a reference to every array it lists for as long as the table
can be run, checks each is C-contiguous with the dtype the op reads, and re-lists a block's arrays
whenever the block may have replaced them; an address therefore always points into a live array of
the recorded shape.

The arena: `V` (rows, C) values and `M` (rows, C) masks; `A[r]` says whether row r holds a frame this
tick (an input from a Python block may be missing). After each op its mask row is compared with the
published copy `P` (what Python readers hold): a changed row is copied there and flagged in `CH`, so a
mask the Python side holds never changes in place (blocks may rely on that, see blocks/mixer.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.blocks.gaze_reach import STILL, STILL_TICKS
from backend.engine.compiled import f8, i8, i8_2
from backend.engine.compiled.blend import mixer_tick
from backend.engine.compiled.clip_clock import clip_clock
from backend.engine.compiled.curves import clip_frame
from backend.engine.compiled.frames import filter_tick, gain_offset_tick, hold_tick, limiter_tick
from backend.engine.compiled.gaze import gaze_tick
from backend.engine.compiled.idle import breathe_tick, noise_tick, offset_tick
from backend.engine.compiled.ik import ik_tick
from backend.engine.compiled.pointers import b1, b2, f1, f2, f3, i1, i2
from backend.engine.compiled.signals import drive, emotion_tick, math_value, py_max, py_min, same_float

# Op codes (column 0); after each, its scalar slots (S[s..]) and refs (columns 4..).
NOP = 0  # a constant frame written when the op is bound (rest_pose)
BREATHE = 1  # S: scale (worked out here), amplitude, inhale, frequency, the amplitude parameter | 4 offset_cycles, 5 amp_values, 6 amp_override, 7 mask,
#               8 phase (1,): read, then stepped by frequency * dt (as Breathe.tick)
NOISE = 2  # S: smooth, gain | 4 x, 5 y, 6 coef, 7 draws (batch, 2, C), 8 mask, 9 draws' cursor (1,): the
#             batch row of this tick's draws, stepped here; a used-up batch asks for `SERVICE`
GAIN_OFFSET = 3  # S: gain, offset | 4 sel
FILTER = 4  # S: one_pass | 4 idx, 5 set-points, 6 cfg, 7 buf (rows, n), 8 an empty mask
LIMITER = 5  # 4 last, 5 lo, 6 hi, 7 vmax, 8 the continuous mask
HOLD = 6  # 4 held (the output block's state, which is its frame)
MIXER = 7  # 4 layer rows, 5 weights, 6 fade_level, 7 fade_target, 8 fade_time, 9 signal_weights, 10 w,
#            11 gathered values (L*C), 12 gathered masks (L*C), 13 layer masks (L, C), 14 mode codes

IK = 10  # S: weight, target xyz, look, lam2, iterations, max_step, converged, null_gain, null_range,
#          chain identity, solve (target, weight > 0, joints), hold (no target: forget the warm start) |
#          4 held, 5 delta, 6 add mask, 7 j_rows (m, C), 8 var, 9 var_ch, 10 constants, 11..20 the chain's
#          arrays in CHAIN_SIG's order (k, k2, axes, revolute, src, mult, off, pre, post, select), 21 the
#          workspace (compiled/ik.py's ik_workspace)
GAZE = 11  # S: strength, target xyz, (unused), arc_dip, arc_max, arc_smoothing, tolerance, chain identity,
#            on target (written), a look_at in progress (cleared here when it ends: `SERVICE`), on target as
#            last published (a change asks for `SERVICE`) | 4 x, 5 x before this tick (written), 6 dip (1,),
#            7 idx, 8 axis, 9 leader, 10 constants, 11 j_rows, 12..21 the chain's arrays in CHAIN_SIG's order,
#            22 mask, 23 the workspace (compiled/gaze.py's gaze_workspace), 24 the still ticks (1,): stepped
#            here while a look_at is in progress (as Gaze._follow_watch)
SINE = 8  # S: offset, amplitude, phi + phase | 4 spread, 5 mask
OFFSET = 9  # S: k, k given (Python advanced this tick: `TRAP`), shift duration | 4 start, 5 target, 6 offset
#             (written), 7 mask, 8 timing (until next, elapsed), stepped here (as WeightShift.advance)
LED = 12  # S: r, g, b, mode, depth, phase (written here), first channel, components, frequency | 4 mask,
#           5 the phase (1,): read, then stepped by frequency * dt (as Led.advance)
LED_SOLID, LED_BREATHE, LED_PULSE = 0.0, 1.0, 2.0  # the LED's mode scalar
# Signal ops: no frame; their outputs are scalar slots, and a changed output flags CH[out] for Python.
# After their last published values, a `lazy` flag (EMOTION_LAZY, MATH_LAZY).
EMOTION = 13  # S: valence and arousal targets, k, 8 constants (compiled/signals.py's emotion_tick), 6 outputs
#              (speed, amplitude, posture_offset, valence, arousal, posture index), their last published
#              values | 4 state (v, a, primed, posture index), 5 postures (n, 2)
MATH = 14  # S: a, b, op code, in_min, in_max, out_min, out_max, clamped, min, max, value, last published |
#           4 the last finite value (1,)
BLINK = (
    15  # S: hold, shifted (this tick: `pre` sets it, the op clears it), scheduled (Python stepped the clock
)
#             this tick: `TRAP`), close, hold and open times, min_interval, blinking as last published | 4 the
#             state's clock (Blink.State.clock), 5 delta, 6 mask
CLIP = 16  # S: speed (driven, else the play's or the parameter), duration, mode code, warp (0/1),
#            a clip (0/1), Python first (a start is pending: `TRAP`), Python ticked it (the kernel skips it
#            once), relative, readers (`SERVICE` every tick: `weight`, `playing` or `time` is wired),
#            weight, (unused), crossfade (0/1), crossfade factor (written) | 4 clock (the block's
#            State.clock), 5 values, 6 from_values, 7 mask, 8 old_mask, 9..15 the clip's curves (t, v,
#            h_right, h_left, code, mode, n_keys), 16 channels, 17 relative, 18 enum, 19 event times,
#            20..21 the anchor warp (play, clip time), 22 the curves' values (K,): scratch
EMOTION_OUT = 11  # the emotion's first output slot (after its s)
EMOTION_OUTPUTS = 6
MATH_OUT = 10
# A signal op's slot saying no step reads its outputs in Python (`lazy`): a change is flagged in CH but
# not counted in `run_ops`' return, and Python publishes it only when asked (`SignalOp.refresh`).
EMOTION_LAZY = EMOTION_OUT + 2 * EMOTION_OUTPUTS
MATH_LAZY = MATH_OUT + 2

#: What `run_ops` adds to its count of changed masks per op asking for Python's `service` after the run (the
#: op flagged in the `SV` array).
SERVICE = 1 << 32
#: `run_ops` stopped at op k, which needs Python's `trap` before it can run (a new weight shift is drawn):
#: it returns its counts so far plus (k + 1) * TRAP, having changed nothing of op k.
TRAP = 1 << 48

#: Columns of an op row; the last lists the op's drives (compiled/signals.py's `drive` table), or -1.
WIDTH = 26
DRIVES = WIDTH - 1

#: refs rows 0.. : the arena's and the robot's arrays, the same for every op.
REF_V, REF_M, REF_A, REF_P, REF_CH, REF_S, REF_REST, REF_LO, REF_HI, REF_ENUM, REF_SV = range(11)
#: The first refs row the ops' own arrays use.
FIRST_OP_REF = 11

RUN_SIG = (i8_2, i8_2, i8, i8, f8)  # ops, refs, k0, k1, dt


@njit(cache=True)
def _publish(r, M, P, CH):
    """Copy mask row r to its published copy when it changed (and flag it)."""
    changed = False
    for c in range(M.shape[1]):
        if M[r, c] != P[r, c]:
            changed = True
            break
    if changed:
        for c in range(M.shape[1]):
            P[r, c] = M[r, c]
        CH[r] = True
    return changed


@njit(cache=True)
def _look_at_ended(x, x_old, still, on):
    """Count the ticks in a row the gaze stood still (`still[0]`, as Gaze._follow_watch); whether the
    look_at in progress ends (on target, or still for STILL_TICKS ticks)."""
    moved = False
    for i in range(x.shape[0]):
        if not abs(x[i] - x_old[i]) < STILL:  # (a NaN moved)
            moved = True
            break
    still[0] = 0.0 if moved else still[0] + 1.0
    return on or still[0] >= STILL_TICKS


@njit(cache=True)
def _moved(S, o, n):
    """Whether the n outputs at S[o..] differ from their last published copies at S[o + n..] (which
    then take them)."""
    moved = False
    for j in range(n):
        if not same_float(S[o + j], S[o + n + j]):
            moved = True
            S[o + n + j] = S[o + j]
    return moved


@njit(cache=True)
def _blink_clock(clock, S, s, dt):
    """Blink.schedule's step of the clock when no blink starts this tick; False (nothing changed) when
    one does (Python's `trap` steps it then). clock: t, next_at, last_onset, active, elapsed, double_at
    (NaN: none), forced."""
    if S[s + 2] > 0.5:  # Python stepped it this tick
        S[s + 2] = 0.0
        S[s + 1] = 0.0
        return True
    t = clock[0] + dt
    if clock[3] < 0.5:  # not blinking
        if clock[6] > 0.5:
            return False
        if S[s] < 0.5:  # not held
            if not math.isnan(clock[5]) and t >= clock[5]:
                return False
            if (S[s + 1] > 0.5 and t - clock[2] > S[s + 6] / 2) or t >= clock[1]:
                return False
        else:
            clock[5] = math.nan  # a held expression cancels a pending second blink
    clock[0] = t
    S[s + 1] = 0.0
    return True


@njit(cache=True)
def _blink_amount(clock, S, s, dt):
    """The lids' closure this tick (Blink.tick after its schedule, and Blink.envelope)."""
    if clock[3] < 0.5:
        return 0.0
    clock[4] = clock[4] + dt
    e, close, hold, opening = clock[4], S[s + 3], S[s + 4], S[s + 5]
    if e >= close + hold + opening:
        clock[3] = 0.0
        return 0.0
    if e <= 0.0:
        return 0.0
    if e < close:
        return 0.5 - 0.5 * math.cos(math.pi * e / close)
    e -= close
    if e < hold:
        return 1.0
    e -= hold
    if e < opening:
        return 0.5 + 0.5 * math.cos(math.pi * e / opening)
    return 0.0


@njit(cache=True)
def _gather(rows, V, M, A, vals, masks):
    """The mixer's layers, layer-major, into `vals`/`masks`; a missing layer as zeros with no mask."""
    n = V.shape[1]
    for i in range(rows.shape[0]):
        r = rows[i]
        present = r >= 0 and A[r]
        for c in range(n):
            vals[i * n + c] = V[r, c] if present else 0.0
            masks[i * n + c] = M[r, c] if present else False


@njit(cache=True)
def _led(S, s, rest, out_row):
    """Led.tick's frame: the rest pose with the colour times the brightness, each component within 0..1
    (a NaN stays NaN, as the block's comparisons leave it)."""
    mode, depth, u = S[s + 3], S[s + 4], S[s + 5]
    factor = 1.0
    if mode == LED_BREATHE:
        factor = 1.0 - depth * (0.5 - 0.5 * math.cos(2.0 * math.pi * u))
    elif mode == LED_PULSE:
        attack = 0.12
        level = 0.5 - 0.5 * math.cos(math.pi * u / attack) if u < attack else math.exp(-5.0 * (u - attack))
        factor = (1.0 - depth) + depth * level
    out_row[:] = rest
    c = np.int64(S[s + 6])
    for i in range(np.int64(S[s + 7])):
        v = S[s + i] * factor
        out_row[c + i] = 0.0 if v < 0.0 else 1.0 if v > 1.0 else v


@njit(cache=True)
def run_ops(ops, refs, k0, k1, dt):
    """Run ops k0..k1-1 (see the module doc); returns how many published masks changed, plus `SERVICE`
    times how many ops asked for Python's `service` after the run.

    Two array arguments only: each array a compiled function receives costs its unboxing (and a small
    allocation) per call, so the arena and the robot's arrays are read from `refs` like the ops' own."""
    V, M, P = f2(refs, REF_V), b2(refs, REF_M), b2(refs, REF_P)
    A, CH, S = b1(refs, REF_A), b1(refs, REF_CH), f1(refs, REF_S)
    rest, lo, hi, enum = f1(refs, REF_REST), f1(refs, REF_LO), f1(refs, REF_HI), b1(refs, REF_ENUM)
    SV = b1(refs, REF_SV)  # the ops that ask for `service` (flagged here, cleared by Python)
    changed = 0
    service = 0
    for k in range(k0, k1):
        code, out, src, s = ops[k, 0], ops[k, 1], ops[k, 2], ops[k, 3]
        r = ops[k]
        has = src >= 0 and A[src]
        if r[DRIVES] >= 0:  # compiled signals into this op's parameters, before it reads them
            drive(S, f2(refs, r[DRIVES]))
        if code == EMOTION:
            o = s + EMOTION_OUT
            x, postures = f1(refs, r[4]), f2(refs, r[5])
            emotion_tick(x, S[s], S[s + 1], S[s + 2], S[s + 3 : s + 11], postures, S[o : o + EMOTION_OUTPUTS])
            if _moved(S, o, EMOTION_OUTPUTS):
                CH[out] = True
                if S[s + EMOTION_LAZY] < 0.5:
                    changed += 1
            continue  # a signal: no frame
        elif code == MATH:
            last = f1(refs, r[4])
            value = math_value(
                np.int64(S[s + 2]), S[s], S[s + 1], S[s + 3], S[s + 4], S[s + 5], S[s + 6], S[s + 7] > 0.5,
                S[s + 8], S[s + 9],
            )  # fmt: skip
            if math.isfinite(value):
                last[0] = value
            S[s + MATH_OUT] = last[0]
            if _moved(S, s + MATH_OUT, 1):
                CH[out] = True
                if S[s + MATH_LAZY] < 0.5:
                    changed += 1
            continue
        elif code == BREATHE:
            mask, phase = b1(refs, r[7]), f1(refs, r[8])
            S[s] = S[s + 1] / S[s + 4] if S[s + 4] > 0 else 1.0  # the amplitude may come from a drive
            breathe_tick(
                phase[0], f1(refs, r[4]), b1(refs, r[6]), f1(refs, r[5]), S[s], S[s + 1], S[s + 2],
                rest, lo, hi, mask, V[out],
            )  # fmt: skip
            phase[0] = (phase[0] + S[s + 3] * dt) % 1.0
            M[out, :] = mask
        elif code == NOISE:
            mask, draws, cursor = b1(refs, r[8]), f3(refs, r[7]), i1(refs, r[9])
            i = cursor[0]
            if i >= draws.shape[0]:  # the op refills a used-up batch before the next run: never here
                raise ValueError("compiled core: a noise op ran on a used-up batch of draws")
            step = dt > 0.0
            noise_tick(
                f1(refs, r[4]), f1(refs, r[5]), draws[i], f1(refs, r[6]), step, S[s] > 0.5, S[s + 1],
                rest, lo, hi, mask, V[out],
            )  # fmt: skip
            if step:
                cursor[0] = i + 1
                if i + 1 >= draws.shape[0]:
                    SV[k] = True
                    service += 1
            M[out, :] = mask
        elif code == SINE:
            spread, mask = f1(refs, r[4]), b1(refs, r[5])
            for c in range(V.shape[1]):  # Sine.tick: rest + offset + amplitude sin(phase), on every channel
                V[out, c] = rest[c] + S[s] + S[s + 1] * math.sin(S[s + 2] + spread[c])
            M[out, :] = mask
        elif code == OFFSET:
            if S[s + 1] > 0.5:  # Python advanced it this tick (a trap)
                S[s + 1] = 0.0
            else:
                timing = f1(refs, r[8])
                until_next = timing[0] - dt
                if until_next <= 0.0:  # a new shift is due: its draws are Python's
                    return changed + service * SERVICE + (k + 1) * TRAP
                timing[0] = until_next
                timing[1] = timing[1] + dt
                u = py_min(timing[1] / S[s + 2], 1.0)
                S[s] = 0.5 - 0.5 * math.cos(math.pi * u)
            mask = b1(refs, r[7])
            offset_tick(f1(refs, r[4]), f1(refs, r[5]), S[s], f1(refs, r[6]), rest, lo, hi, mask, V[out])
            M[out, :] = mask
        elif code == BLINK:
            clock, delta, mask = f1(refs, r[4]), f1(refs, r[5]), b1(refs, r[6])
            if not _blink_clock(clock, S, s, dt):
                return changed + service * SERVICE + (k + 1) * TRAP  # a blink starts: Python's draws
            amount = _blink_amount(clock, S, s, dt)
            if clock[3] != S[s + 7]:  # it started or ended: `blinking` for Python's readers
                S[s + 7] = clock[3]
                SV[k] = True
                service += 1
            for c in range(V.shape[1]):
                v = py_min(py_max(rest[c] + amount * delta[c], lo[c]), hi[c])
                V[out, c] = v if mask[c] else rest[c]
            M[out, :] = mask
        elif code == LED:
            phase = f1(refs, r[5])
            S[s + 5] = phase[0] % 1.0
            phase[0] = (phase[0] + S[s + 8] * dt) % 1.0
            _led(S, s, rest, V[out])
            M[out, :] = b1(refs, r[4])
        elif code == GAIN_OFFSET:
            if has:
                gain_offset_tick(V[src], rest, b1(refs, r[4]), S[s], S[s + 1], V[out])
                M[out, :] = M[src]
            else:  # an operator without a frame in gives the empty frame
                V[out, :] = 0.0
                M[out, :] = False
        elif code == FILTER:
            idx, sp, cfg, buf = i1(refs, r[4]), f1(refs, r[5]), f1(refs, r[6]), f2(refs, r[7])
            if has:
                filter_tick(V[src], M[src], True, idx, sp, buf, cfg, S[s] > 0.5, rest, V[out], M[out])
            else:
                filter_tick(rest, b1(refs, r[8]), False, idx, sp, buf, cfg, S[s] > 0.5, rest, V[out], M[out])
        elif code == LIMITER:
            last, lim_lo, lim_hi, vmax = f1(refs, r[4]), f1(refs, r[5]), f1(refs, r[6]), f1(refs, r[7])
            if has:
                limiter_tick(V[src], M[src], True, last, lim_lo, lim_hi, vmax, dt)
            else:
                limiter_tick(last, b1(refs, r[8]), False, last, lim_lo, lim_hi, vmax, dt)
            V[out, :] = last
            M[out, :] = True
        elif code == IK:
            if not has:  # an operator without a frame in gives the empty frame (its state stands still)
                V[out, :] = 0.0
                M[out, :] = False
            elif S[s + 13] > 0.5:
                ik_tick(
                    V[src], M[src], f1(refs, r[4]), S[s + 1 : s + 4], S[s], f1(refs, r[5]), V[out], M[out],
                    b1(refs, r[6]), f2(refs, r[7]), i1(refs, r[8]), i1(refs, r[9]), f1(refs, r[10]),
                    S[s + 4] > 0.5, S[s + 5], np.int64(S[s + 6]), S[s + 7], S[s + 8], S[s + 9], S[s + 10],
                    f3(refs, r[11]), f3(refs, r[12]), f2(refs, r[13]), f1(refs, r[14]), i1(refs, r[15]),
                    f1(refs, r[16]), f1(refs, r[17]), f3(refs, r[18]), f2(refs, r[19]), f2(refs, r[20]),
                    S[s + 12] > 0.5, f1(refs, r[21]),
                )  # fmt: skip
            else:  # IK.transform without a solve: hold what the frame sets, pass it through unchanged
                held = f1(refs, r[4])
                for c in range(V.shape[1]):
                    if M[src, c]:
                        held[c] = V[src, c]
                    V[out, c] = V[src, c]
                    M[out, c] = M[src, c]
                if S[s + 14] > 0.5:
                    delta = f1(refs, r[5])
                    delta[:] = 0.0
        elif code == GAZE:
            x, x_old = f1(refs, r[4]), f1(refs, r[5])
            x_old[:] = x  # the block's tick steps a copy; the op keeps the old x for its watch instead
            on = gaze_tick(
                x, f1(refs, r[6]), V[out], S[s + 1 : s + 4], S[s], dt, i1(refs, r[7]), i1(refs, r[8]),
                b1(refs, r[9]), f1(refs, r[10]), S[s + 5], S[s + 6], S[s + 7], S[s + 8], f2(refs, r[11]),
                f3(refs, r[12]), f3(refs, r[13]), f2(refs, r[14]), f1(refs, r[15]), i1(refs, r[16]),
                f1(refs, r[17]), f1(refs, r[18]), f3(refs, r[19]), f2(refs, r[20]), f2(refs, r[21]),
                S[s + 9] > 0.5, f1(refs, r[23]),
            )  # fmt: skip
            S[s + 10] = 1.0 if on else 0.0
            if S[s + 10] != S[s + 12]:  # on_target changed: for Python's readers
                S[s + 12] = S[s + 10]
                SV[k] = True
                service += 1
            if S[s + 11] > 0.5 and _look_at_ended(x, x_old, f1(refs, r[24]), on):
                S[s + 11] = 0.0
                SV[k] = True
                service += 1
            M[out, :] = b1(refs, r[22])
        elif code == CLIP:
            if S[s + 6] > 0.5:  # Python ran the block's own tick into the row (its `trap`)
                S[s + 6] = 0.0
            elif S[s + 4] < 0.5:  # no clip: the pose shown, out of sight
                if S[s + 5] > 0.5:
                    return changed + service * SERVICE + (k + 1) * TRAP
                V[out, :] = f1(refs, r[5])
                M[out, :] = False
            else:
                clock = f1(refs, r[4])
                if S[s + 5] > 0.5 or not clip_clock(
                    clock, S, s, dt, f1(refs, r[19]), f1(refs, r[20]), f1(refs, r[21])
                ):
                    return changed + service * SERVICE + (k + 1) * TRAP
                mask, old_mask = b1(refs, r[7]), b1(refs, r[8])
                clip_frame(
                    f2(refs, r[9]), f2(refs, r[10]), f3(refs, r[11]), f3(refs, r[12]), i2(refs, r[13]),
                    i2(refs, r[14]), i1(refs, r[15]), clock[0], i1(refs, r[16]), b1(refs, r[17]),
                    b1(refs, r[18]), rest, f1(refs, r[5]), S[s + 11] > 0.5, S[s + 12], f1(refs, r[6]),
                    old_mask, mask, S[s + 7] > 0.5, S[s + 9], V[out], f1(refs, r[22]),
                )  # fmt: skip
                both = clock[5] < clock[6]  # (after the crossfade's step, as ClipPlayer._tick_compiled)
                for c in range(M.shape[1]):
                    M[out, c] = mask[c] or (both and old_mask[c])
            if S[s + 8] > 0.5:
                SV[k] = True
                service += 1
        elif code == HOLD:
            if has:  # without a frame in, the output holds (as Output.tick)
                hold_tick(V[src], M[src], f1(refs, r[4]), lo, hi)
            continue  # the output's frame is its held state: no arena row
        elif code == MIXER:
            vals, masks = f1(refs, r[11]), b1(refs, r[12])
            _gather(i1(refs, r[4]), V, M, A, vals, masks)
            mixer_tick(
                vals, masks, b2(refs, r[13]), f1(refs, r[5]), f1(refs, r[6]), f1(refs, r[7]), f1(refs, r[8]),
                f1(refs, r[9]), dt, i1(refs, r[14]), rest, rest, enum, V[out], M[out], f1(refs, r[10]),
            )  # fmt: skip
        A[out] = True
        if _publish(out, M, P, CH):
            changed += 1
    return changed + service * SERVICE
