"""The compiled tick of the gaze block: eyes, head and body turned toward a target with the chain's
forward kinematics (`backend.engine.compiled.kinematics`), within their position and velocity limits.

The numpy reference is `Gaze.tick` (backend/engine/blocks/gaze.py). Units: m, rad and s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.compiled import b1_1, f8, f8_1, f8_2, i8_1
from backend.engine.compiled.kinematics import (
    CHAIN_SIG,
    _frames_into,
    _joint_positions_into,
)


@njit(cache=True)
def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True)
def _limit_into(old, new, lo, hi, vmax, dt, out):
    """`Gaze._limit` into `out` (may be `new`): within the position limits, and at most vmax * dt from
    `old`."""
    for i in range(old.shape[0]):
        step = vmax[i] * dt
        out[i] = old[i] + min(max(min(max(new[i], lo[i]), hi[i]) - old[i], -step), step)


def gaze_workspace(n_channels: int, n_gaze: int, n_joints: int, n_moving: int) -> np.ndarray:
    """The scratch one gaze kernel call works in (`_gaze_tick` carves it, in this order): the pose
    (n_channels,), the chain's joints, its frames (n_moving, 4, 4) and four 4x4, the eye (3,), per gaze
    DoF the old angles, goals, targets and steps, and three per-axis pairs. Made once per
    configuration, so a tick allocates nothing."""
    return np.zeros(n_channels + n_joints + 16 * n_moving + 64 + 3 + 4 * n_gaze + 6)


def gaze_constants(
    rest, gain, share, follow_share, follow_total, tau, lo, hi, vmax, eye_offset, j_off, jlo, jhi
):
    """The gaze kernel's constant vectors in one array, in the order `gaze_tick` reads them back: rest (C,);
    gain, share, follow_share (n,); follow_total (2,); tau, lo, hi, vmax (n,); eye_offset (3,); j_off,
    jlo, jhi (m,) (one argument to convert per call instead of thirteen)."""
    return np.ascontiguousarray(
        np.concatenate(
            [rest, gain, share, follow_share, follow_total, tau, lo, hi, vmax, eye_offset, j_off, jlo, jhi]
        ),
        dtype=np.float64,
    )


@njit(cache=True)
def gaze_tick(
    x,
    dip,
    out,
    target,
    strength,
    dt,
    idx,
    axis,
    leader,
    consts,
    arc_dip,
    arc_max,
    arc_smoothing,
    tolerance,
    j_rows,
    k,
    k2,
    axes,
    rev,
    src,
    mult,
    off,
    pre,
    post,
    select,
    identity,
    ws,
):
    """One gaze tick (see `_gaze_tick`) with its constant vectors packed by `gaze_constants`, working in
    `ws` (`gaze_workspace`)."""
    n, c, m = x.shape[0], out.shape[0], j_rows.shape[0]
    o = c + 3 * n + 2
    o2 = o + 4 * n + 3
    return _gaze_tick(
        x,
        dip,
        out,
        target,
        strength,
        dt,
        consts[:c],
        idx,
        axis,
        leader,
        consts[c : c + n],
        consts[c + n : c + 2 * n],
        consts[c + 2 * n : c + 3 * n],
        consts[c + 3 * n : o],
        consts[o : o + n],
        consts[o + n : o + 2 * n],
        consts[o + 2 * n : o + 3 * n],
        consts[o + 3 * n : o + 4 * n],
        arc_dip,
        arc_max,
        arc_smoothing,
        tolerance,
        consts[o + 4 * n : o2],
        j_rows,
        consts[o2 : o2 + m],
        consts[o2 + m : o2 + 2 * m],
        consts[o2 + 2 * m : o2 + 3 * m],
        k,
        k2,
        axes,
        rev,
        src,
        mult,
        off,
        pre,
        post,
        select,
        identity,
        ws,
    )


@njit(cache=True)
def _gaze_tick(
    x,
    dip,
    out,
    target,
    strength,
    dt,
    rest,
    idx,
    axis,
    leader,
    gain,
    share,
    follow_share,
    follow_total,
    tau,
    lo,
    hi,
    vmax,
    arc_dip,
    arc_max,
    arc_smoothing,
    tolerance,
    eye_offset,
    j_rows,
    j_off,
    jlo,
    jhi,
    k,
    k2,
    axes,
    rev,
    src,
    mult,
    off,
    pre,
    post,
    select,
    identity,
    ws,
):
    """One gaze tick (see `Gaze.tick`): the gaze DoFs' angles from rest `x` (n,) and the arc dip
    `dip` (1,) advance in place; `out` (C,) receives rest + the gaze angles. Returns on_target. Every
    scratch array is a view of `ws` (`gaze_workspace`)."""
    n, nc, nj, m = x.shape[0], rest.shape[0], j_off.shape[0], pre.shape[0]
    values, q = ws[:nc], ws[nc : nc + nj]
    o = nc + nj
    frames = ws[o : o + 16 * m].reshape((m, 4, 4))
    o += 16 * m
    pose, t4 = ws[o : o + 16].reshape((4, 4)), ws[o + 16 : o + 32].reshape((4, 4))
    motion, tmp = ws[o + 32 : o + 48].reshape((4, 4)), ws[o + 48 : o + 64].reshape((4, 4))
    eye = ws[o + 64 : o + 67]
    o += 67
    x_old, goal, target_x, xs = (
        ws[o : o + n],
        ws[o + n : o + 2 * n],
        ws[o + 2 * n : o + 3 * n],
        ws[o + 3 * n : o + 4 * n],
    )
    o += 4 * n
    desired, taken, followers = ws[o : o + 2], ws[o + 2 : o + 4], ws[o + 4 : o + 6]
    if o + 6 > ws.shape[0]:  # slices stop at the end: a short workspace would be written past it
        raise ValueError("the gaze workspace is smaller than this chain needs (gaze_workspace)")
    values[:] = rest
    for i in range(n):
        values[idx[i]] += x[i]
    _joint_positions_into(values, j_rows, j_off, jlo, jhi, q)
    _frames_into(q, k, k2, axes, rev, src, mult, off, pre, post, identity, frames, pose, t4, motion, tmp)
    for r in range(3):
        eye[r] = (
            pose[r, 0] * eye_offset[0] + pose[r, 1] * eye_offset[1] + pose[r, 2] * eye_offset[2] + pose[r, 3]
        )
    l0, l1, l2 = pose[0, 0], pose[1, 0], pose[2, 0]
    r0, r1, r2 = target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]
    dist = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    x_old[:] = x
    if dist > 1e-6:
        u0, u1, u2 = r0 / dist, r1 / dist, r2 / dist
        on_target = math.acos(min(1.0, l0 * u0 + l1 * u1 + l2 * u2)) < tolerance
        ty, tp = math.atan2(u1, u0), math.atan2(-u2, math.hypot(u0, u1))
        ly, lp = math.atan2(l1, l0), math.atan2(-l2, math.hypot(l0, l1))
        desired[:] = 0.0
        for i in range(n):
            desired[axis[i]] += gain[i] * x_old[i]
        desired[0] += _wrap(ty - ly)
        desired[1] += tp - lp
        # Followers: their share, lagged per stage; then the leader of each axis makes up the rest.
        for i in range(n):
            goal[i] = min(max(share[i] * desired[axis[i]] / gain[i], lo[i]), hi[i])
        # What a DoF at its limit cannot take goes to the followers of its axis.
        taken[:] = 0.0
        for i in range(n):
            taken[axis[i]] += gain[i] * goal[i]
        for i in range(n):
            a = axis[i]
            missing = desired[a] - taken[a]
            goal[i] = min(
                max(goal[i] + (missing / follow_total[a]) * follow_share[i] / gain[i], lo[i]), hi[i]
            )
        for i in range(n):
            alpha = 1.0 - math.exp(-dt / max(tau[i], 1e-9))
            target_x[i] = x_old[i] + alpha * (goal[i] - x_old[i])
        _limit_into(x_old, target_x, lo, hi, vmax, dt, xs)
        followers[:] = 0.0
        for i in range(n):
            if not leader[i]:
                followers[axis[i]] += gain[i] * xs[i]
        for i in range(n):
            if leader[i]:
                xs[i] = (desired[axis[i]] - followers[axis[i]]) / gain[i]
        _limit_into(x_old, xs, lo, hi, vmax, dt, xs)
        for i in range(n):
            x[i] = xs[i]
    else:
        on_target = True
    # Arcs: a pitch dip that follows the (smoothed) yaw speed, outside the gaze feedback loop.
    turn = 0.0
    for i in range(n):
        if axis[i] == 0:
            turn += gain[i] * (x[i] - x_old[i])
    yaw_speed = abs(turn) / max(dt, 1e-9)
    dip_goal = min(arc_dip * yaw_speed, arc_max)
    dip[0] += (1.0 - math.exp(-dt / arc_smoothing)) * (dip_goal - dip[0])
    for c in range(out.shape[0]):
        out[c] = rest[c]
    for i in range(n):
        rel = x[i] + (share[i] * dip[0] / gain[i] if axis[i] == 1 else 0.0)
        out[idx[i]] += min(max(strength * rel, lo[i]), hi[i])
    return on_target


GAZE_SIG = (f8_1, f8_1, f8_1, f8_1, f8, f8, i8_1, i8_1, b1_1, f8_1, f8, f8, f8, f8, f8_2, *CHAIN_SIG, f8_1)
