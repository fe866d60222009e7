"""Compiled forward kinematics of one `Chain`, and on it the whole tick of the IK and gaze blocks.

The numpy references are `Chain.kinematics` / `Chain.fk` (backend/engine/kinematics.py),
`InverseKinematics.transform` and `Gaze.tick`; these kernels do the same arithmetic in loops over
the chain's few joints (m, 3 and 4x4 sized work, where numpy's per-call overhead was the whole cost).
Units: m and rad. A chain is passed as the arrays of `chain_args` (see `CHAIN_SIG`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.compiled import b1, b1_1, f8, f8_1, f8_2, f8_3, i8, i8_1

#: The chain's arrays as the kernels take them (`chain_args`): skew matrices K and K² of the joint
#: axes (m, 3, 3), the axes (m, 3), revolute flags (m,), mimic map src/mult/off (m,), the fixed
#: transforms before each moving joint (m, 4, 4) and after the last (4, 4), d(moving)/dq (m, n),
#: and whether the moving joints are the actuated ones in order.
CHAIN_SIG = (f8_3, f8_3, f8_2, f8_1, i8_1, f8_1, f8_1, f8_3, f8_2, f8_2, b1)


def chain_args(chain) -> tuple:
    """The arrays of a `backend.engine.kinematics.Chain` in the order of `CHAIN_SIG` (contiguous)."""
    c = np.ascontiguousarray
    return (
        c(chain._k),
        c(chain._k2),
        c(chain._axes),
        c(chain._revolute.astype(float)),
        c(chain._src.astype(np.int64)),
        c(chain._mult),
        c(chain._off),
        c(chain._pre),
        c(chain._post),
        c(chain._select),
        bool(chain._identity_map),
    )


@njit(cache=True)
def _matmul(a, b):
    """a @ b for small 2-D arrays (numba's own `@` needs SciPy's BLAS, which nutty does not depend on)."""
    n, m, p = a.shape[0], a.shape[1], b.shape[1]
    out = np.empty((n, p))
    for i in range(n):
        for j in range(p):
            s = 0.0
            for k in range(m):
                s += a[i, k] * b[k, j]
            out[i, j] = s
    return out


@njit(cache=True)
def _mul4_into(a, b, out):
    """out = a @ b for 4x4 matrices, in the order of `_matmul`'s sums (the same result, bit for bit);
    `out` must not be `a` or `b`."""
    for i in range(4):
        for j in range(4):
            s = 0.0
            for k in range(4):
                s += a[i, k] * b[k, j]
            out[i, j] = s


@njit(cache=True)
def _frames_into(q, k, k2, axes, rev, src, mult, off, pre, post, identity, frames, tip, t, motion, tmp):
    """`_frames` into given buffers: joint frames (m, 4, 4) and tip pose (4, 4); t, motion, tmp: (4, 4)
    scratch. The same arithmetic as `_frames`, without an allocation."""
    m = pre.shape[0]
    for r in range(4):
        for col in range(4):
            t[r, col] = 1.0 if r == col else 0.0
            motion[r, col] = 1.0 if r == col else 0.0
    for j in range(m):
        v = q[j] if identity else mult[j] * q[src[j]] + off[j]
        _mul4_into(t, pre[j], tmp)
        for r in range(4):
            for col in range(4):
                frames[j, r, col] = tmp[r, col]
        if rev[j] != 0.0:  # R = I + sin(v) K + (1 - cos(v)) K²
            s, c1 = math.sin(v), 1.0 - math.cos(v)
            for r in range(3):
                for col in range(3):
                    motion[r, col] = (1.0 if r == col else 0.0) + s * k[j, r, col] + c1 * k2[j, r, col]
                motion[r, 3] = 0.0
        else:
            for r in range(3):
                for col in range(3):
                    motion[r, col] = 1.0 if r == col else 0.0
                motion[r, 3] = axes[j, r] * v
        _mul4_into(tmp, motion, t)
    _mul4_into(t, post, tip)


@njit(cache=True)
def _frames(q, k, k2, axes, rev, src, mult, off, pre, post, identity):
    """Joint frames before their motion (m, 4, 4) and the tip pose (4, 4) for chain positions q."""
    frames = np.empty((pre.shape[0], 4, 4))
    tip = np.empty((4, 4))
    _frames_into(
        q,
        k,
        k2,
        axes,
        rev,
        src,
        mult,
        off,
        pre,
        post,
        identity,
        frames,
        tip,
        np.empty((4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
    )
    return frames, tip


@njit(cache=True)
def _kinematics_into(
    q,
    point,
    direction,
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
    frames,
    tip,
    t,
    motion,
    tmp,
    p,
    d,
    jp_m,
    jd_m,
):
    """`_kinematics` into given buffers: p, d (3,); jp_m, jd_m (3, m): the Jacobians over the chain's
    moving joints (the caller maps them by `select` unless `identity`); frames, tip, t, motion, tmp:
    `_frames_into`'s. The same arithmetic as `_kinematics`."""
    _frames_into(q, k, k2, axes, rev, src, mult, off, pre, post, identity, frames, tip, t, motion, tmp)
    m = pre.shape[0]
    for r in range(3):
        p[r] = tip[r, 0] * point[0] + tip[r, 1] * point[1] + tip[r, 2] * point[2] + tip[r, 3]
        d[r] = tip[r, 0] * direction[0] + tip[r, 1] * direction[1] + tip[r, 2] * direction[2]
    for j in range(m):
        z0 = frames[j, 0, 0] * axes[j, 0] + frames[j, 0, 1] * axes[j, 1] + frames[j, 0, 2] * axes[j, 2]
        z1 = frames[j, 1, 0] * axes[j, 0] + frames[j, 1, 1] * axes[j, 1] + frames[j, 1, 2] * axes[j, 2]
        z2 = frames[j, 2, 0] * axes[j, 0] + frames[j, 2, 1] * axes[j, 1] + frames[j, 2, 2] * axes[j, 2]
        if rev[j] != 0.0:
            e0, e1, e2 = p[0] - frames[j, 0, 3], p[1] - frames[j, 1, 3], p[2] - frames[j, 2, 3]
            jp_m[0, j], jp_m[1, j], jp_m[2, j] = z1 * e2 - z2 * e1, z2 * e0 - z0 * e2, z0 * e1 - z1 * e0
            jd_m[0, j] = z1 * d[2] - z2 * d[1]
            jd_m[1, j] = z2 * d[0] - z0 * d[2]
            jd_m[2, j] = z0 * d[1] - z1 * d[0]
        else:
            jp_m[0, j], jp_m[1, j], jp_m[2, j] = z0, z1, z2
            jd_m[0, j] = jd_m[1, j] = jd_m[2, j] = 0.0


@njit(cache=True)
def _kinematics(q, point, direction, k, k2, axes, rev, src, mult, off, pre, post, select, identity):
    """Point p and direction d fixed in the tip frame, in the base frame, and their Jacobians (3, n)."""
    m = pre.shape[0]
    p = np.empty(3)
    d = np.empty(3)
    jp_m = np.empty((3, m))
    jd_m = np.empty((3, m))
    _kinematics_into(
        q,
        point,
        direction,
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
        np.empty((m, 4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
        p,
        d,
        jp_m,
        jd_m,
    )
    if identity:
        return p, d, jp_m, jd_m
    return p, d, _matmul(jp_m, select), _matmul(jd_m, select)


@njit(cache=True)
def _joint_positions(values, rows, offset, lower, upper):
    """The chain's joint positions for a channel vector: clip(rows @ values + offset, lower, upper)."""
    q = np.empty(offset.shape[0])
    for i in range(offset.shape[0]):
        s = 0.0
        for c in range(values.shape[0]):
            s += rows[i, c] * values[c]
        q[i] = min(max(s + offset[i], lower[i]), upper[i])
    return q


@njit(cache=True)
def _inv3_into(a, out):
    """Inverse of a 3x3 matrix (the damped normal matrix: symmetric positive definite) by cofactors, into
    `out` (3, 3)."""
    out[0, 0] = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    out[0, 1] = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    out[0, 2] = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    out[1, 0] = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    out[1, 1] = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    out[1, 2] = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    out[2, 0] = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    out[2, 1] = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    out[2, 2] = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    det = a[0, 0] * out[0, 0] + a[0, 1] * out[1, 0] + a[0, 2] * out[2, 0]
    for i in range(3):
        for j in range(3):
            out[i, j] = out[i, j] / det


@njit(cache=True)
def _dls_step_into(jac, err, moved, size, lam2, null_gain, null_range, a, inv, pinv, dq, jm, back):
    """`InverseKinematics._step` into `dq` (nv,): damped least squares for `err`, plus a pull back by `moved`
    within the task's null space while the error is small; a, inv (3, 3), pinv (nv, 3),
    jm (3,) and back (nv,) are scratch."""
    nv = jac.shape[1]
    for i in range(3):  # a = jac @ jac.T
        for j in range(3):
            acc = 0.0
            for k in range(nv):
                acc += jac[i, k] * jac[j, k]
            a[i, j] = acc
    for r in range(3):
        a[r, r] += lam2
    _inv3_into(a, inv)
    for i in range(nv):  # pinv = jac.T @ inv
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += jac[k, i] * inv[k, j]
            pinv[i, j] = acc
    for i in range(nv):  # dq = pinv @ err
        acc = 0.0
        for k in range(3):
            acc += pinv[i, k] * err[k]
        dq[i] = acc
    pull = null_gain * (1.0 - size / null_range)
    if pull > 0.0:
        for i in range(3):  # jm = jac @ moved
            acc = 0.0
            for k in range(nv):
                acc += jac[i, k] * moved[k]
            jm[i] = acc
        for i in range(nv):  # back = pinv @ jm
            acc = 0.0
            for k in range(3):
                acc += pinv[i, k] * jm[k]
            back[i] = acc
        for j in range(nv):
            dq[j] -= pull * (moved[j] - back[j])


def ik_constants(j_off, lower, upper, dof_lo, dof_hi, offset, axis):
    """The IK kernel's constant vectors in one array, in the order `ik_tick` reads them back: j_off, lower,
    upper (m,); dof_lo, dof_hi (nv,); offset, axis (3,) (one argument to convert per call instead of seven)."""
    return np.ascontiguousarray(
        np.concatenate([j_off, lower, upper, dof_lo, dof_hi, offset, axis]), dtype=np.float64
    )


@njit(cache=True)
def ik_tick(
    frame_values,
    frame_mask,
    values,
    target,
    weight,
    delta,
    out,
    out_mask,
    add_mask,
    j_rows,
    var,
    var_ch,
    consts,
    look,
    lam2,
    iterations,
    max_step,
    converged,
    null_gain,
    null_range,
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
):
    """One IK tick (see `_ik_tick`) with its constant vectors packed by `ik_constants`."""
    m, nv = j_rows.shape[0], var.shape[0]
    o = 3 * m + 2 * nv
    _ik_tick(
        frame_values,
        frame_mask,
        values,
        target,
        weight,
        delta,
        out,
        out_mask,
        add_mask,
        j_rows,
        consts[:m],
        consts[m : 2 * m],
        consts[2 * m : 3 * m],
        var,
        var_ch,
        consts[3 * m : 3 * m + nv],
        consts[3 * m + nv : o],
        consts[o : o + 3],
        consts[o + 3 : o + 6],
        look,
        lam2,
        iterations,
        max_step,
        converged,
        null_gain,
        null_range,
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
    )


@njit(cache=True)
def _ik_tick(
    frame_values,
    frame_mask,
    values,
    target,
    weight,
    delta,
    out,
    out_mask,
    add_mask,
    j_rows,
    j_off,
    lower,
    upper,
    var,
    var_ch,
    dof_lo,
    dof_hi,
    offset,
    axis,
    look,
    lam2,
    iterations,
    max_step,
    converged,
    null_gain,
    null_range,
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
):
    """One IK tick (see `InverseKinematics.transform`): the stage-1 pose `values` (C,) takes the frame's
    set channels (in place); from it and last tick's correction `delta` (updated in place), solve
    toward `target` and write the frame with the moved joint DoFs, blended by `weight`, to `out`
    (its mask, with `add_mask`, to `out_mask`)."""
    for c in range(values.shape[0]):
        if frame_mask[c]:
            values[c] = frame_values[c]
        out[c] = frame_values[c]
        out_mask[c] = frame_mask[c] or add_mask[c]
    nv = var.shape[0]
    q0 = _joint_positions(values, j_rows, j_off, lower, upper)
    ch = np.empty(nv)
    lo = np.empty(nv)
    hi = np.empty(nv)
    q = q0.copy()
    for j in range(nv):
        v = var[j]
        ch[j] = values[var_ch[j]]
        lo[j] = max(lower[v], q0[v] + dof_lo[j] - ch[j])
        hi[j] = min(upper[v], q0[v] + dof_hi[j] - ch[j])
        q[v] = min(max(q0[v] + delta[j], lo[j]), hi[j])
    jac = np.empty((3, nv))
    moved = np.empty(nv)
    err = np.empty(3)
    # the forward kinematics' buffers, reused by every iteration
    m = pre.shape[0]
    frames, tip, t4, motion, tmp = (
        np.empty((m, 4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
        np.empty((4, 4)),
    )
    point, d, jp_m, jd_m = np.empty(3), np.empty(3), np.empty((3, m)), np.empty((3, m))
    # the damped least squares' buffers
    a3, inv3, pinv, jm, back = (
        np.empty((3, 3)),
        np.empty((3, 3)),
        np.empty((nv, 3)),
        np.empty(3),
        np.empty(nv),
    )
    dq = np.empty(nv)
    blocked = np.empty(nv, dtype=np.bool_)
    for _ in range(iterations):
        _kinematics_into(
            q,
            offset,
            axis,
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
            frames,
            tip,
            t4,
            motion,
            tmp,
            point,
            d,
            jp_m,
            jd_m,
        )
        if identity:
            jp, jd = jp_m, jd_m
        else:
            jp, jd = _matmul(jp_m, select), _matmul(jd_m, select)
        if look:
            r0, r1, r2 = target[0] - point[0], target[1] - point[1], target[2] - point[2]
            dist = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            if dist < 1e-6:
                break
            u0, u1, u2 = r0 / dist, r1 / dist, r2 / dist
            cos = u0 * d[0] + u1 * d[1] + u2 * d[2]
            t0, t1, t2 = u0 - cos * d[0], u1 - cos * d[1], u2 - cos * d[2]
            sin = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            angle = math.atan2(sin, cos)
            if angle < converged:
                break
            size = angle
            if sin > 1e-9:
                g = angle / sin
                err[0], err[1], err[2] = t0 * g, t1 * g, t2 * g
            else:  # exactly behind: turn about the base z axis
                err[0], err[1], err[2] = -d[1] * angle, d[0] * angle, 0.0
            for j in range(nv):
                v = var[j]
                uj = u0 * jp[0, v] + u1 * jp[1, v] + u2 * jp[2, v]
                jac[0, j] = jd[0, v] + (jp[0, v] - u0 * uj) / dist
                jac[1, j] = jd[1, v] + (jp[1, v] - u1 * uj) / dist
                jac[2, j] = jd[2, v] + (jp[2, v] - u2 * uj) / dist
        else:
            err[0], err[1], err[2] = target[0] - point[0], target[1] - point[1], target[2] - point[2]
            size = math.sqrt(err[0] * err[0] + err[1] * err[1] + err[2] * err[2])
            if size < converged:
                break
            for j in range(nv):
                for r in range(3):
                    jac[r, j] = jp[r, var[j]]
        for j in range(nv):
            moved[j] = q[var[j]] - q0[var[j]]
        _dls_step_into(jac, err, moved, size, lam2, null_gain, null_range, a3, inv3, pinv, dq, jm, back)
        # Active set: joints the step would push past a limit leave the problem, the rest re-solve.
        any_blocked = False
        for j in range(nv):
            qv = q[var[j]]
            blocked[j] = (qv <= lo[j] and dq[j] < 0.0) or (qv >= hi[j] and dq[j] > 0.0)
            any_blocked = any_blocked or blocked[j]
        if any_blocked:
            for j in range(nv):
                if blocked[j]:
                    jac[0, j] = jac[1, j] = jac[2, j] = 0.0
            _dls_step_into(jac, err, moved, size, lam2, null_gain, null_range, a3, inv3, pinv, dq, jm, back)
            for j in range(nv):
                if blocked[j]:
                    dq[j] = 0.0
        sq = 0.0  # np.sum(dq * dq): a sum in order
        for j in range(nv):
            sq += dq[j] * dq[j]
        norm = math.sqrt(sq)
        if norm > max_step:
            dq *= max_step / norm
        for j in range(nv):
            v = var[j]
            q[v] = min(max(q[v] + dq[j], lo[j]), hi[j])
    for j in range(nv):
        v = var[j]
        delta[j] = q[v] - q0[v]
        out[var_ch[j]] = ch[j] + weight * delta[j]


IK_SIG = (
    f8_1,
    b1_1,
    f8_1,
    f8_1,
    f8,
    f8_1,
    f8_1,
    b1_1,
    b1_1,
    f8_2,
    i8_1,
    i8_1,
    f8_1,
    b1,
    f8,
    i8,
    f8,
    f8,
    f8,
    f8,
    *CHAIN_SIG,
)


@njit(cache=True)
def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True)
def _limit(old, new, lo, hi, vmax, dt):
    """`Gaze._limit`: within the position limits, and at most vmax * dt from `old`."""
    out = np.empty(old.shape[0])
    for i in range(old.shape[0]):
        step = vmax[i] * dt
        out[i] = old[i] + min(max(min(max(new[i], lo[i]), hi[i]) - old[i], -step), step)
    return out


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
):
    """One gaze tick (see `_gaze_tick`) with its constant vectors packed by `gaze_constants`."""
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
):
    """One gaze tick (see `Gaze.tick`): the gaze DoFs' angles from rest `x` (n,) and the arc dip
    `dip` (1,) advance in place; `out` (C,) receives rest + the gaze angles. Returns on_target."""
    n = x.shape[0]
    values = rest.copy()
    for i in range(n):
        values[idx[i]] += x[i]
    q = _joint_positions(values, j_rows, j_off, jlo, jhi)
    _, pose = _frames(q, k, k2, axes, rev, src, mult, off, pre, post, identity)
    eye = np.empty(3)
    for r in range(3):
        eye[r] = (
            pose[r, 0] * eye_offset[0] + pose[r, 1] * eye_offset[1] + pose[r, 2] * eye_offset[2] + pose[r, 3]
        )
    l0, l1, l2 = pose[0, 0], pose[1, 0], pose[2, 0]
    r0, r1, r2 = target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]
    dist = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    x_old = x.copy()
    if dist > 1e-6:
        u0, u1, u2 = r0 / dist, r1 / dist, r2 / dist
        on_target = math.acos(min(1.0, l0 * u0 + l1 * u1 + l2 * u2)) < tolerance
        ty, tp = math.atan2(u1, u0), math.atan2(-u2, math.hypot(u0, u1))
        ly, lp = math.atan2(l1, l0), math.atan2(-l2, math.hypot(l0, l1))
        desired = np.zeros(2)
        for i in range(n):
            desired[axis[i]] += gain[i] * x_old[i]
        desired[0] += _wrap(ty - ly)
        desired[1] += tp - lp
        # Followers: their share, lagged per stage; then the leader of each axis makes up the rest.
        goal = np.empty(n)
        for i in range(n):
            goal[i] = min(max(share[i] * desired[axis[i]] / gain[i], lo[i]), hi[i])
        # What a DoF at its limit cannot take goes to the followers of its axis.
        taken = np.zeros(2)
        for i in range(n):
            taken[axis[i]] += gain[i] * goal[i]
        missing = desired - taken
        for i in range(n):
            a = axis[i]
            goal[i] = min(
                max(goal[i] + (missing[a] / follow_total[a]) * follow_share[i] / gain[i], lo[i]), hi[i]
            )
        target_x = np.empty(n)
        for i in range(n):
            alpha = 1.0 - math.exp(-dt / max(tau[i], 1e-9))
            target_x[i] = x_old[i] + alpha * (goal[i] - x_old[i])
        xs = _limit(x_old, target_x, lo, hi, vmax, dt)
        followers = np.zeros(2)
        for i in range(n):
            if not leader[i]:
                followers[axis[i]] += gain[i] * xs[i]
        for i in range(n):
            if leader[i]:
                xs[i] = (desired[axis[i]] - followers[axis[i]]) / gain[i]
        xs = _limit(x_old, xs, lo, hi, vmax, dt)
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


GAZE_SIG = (f8_1, f8_1, f8_1, f8_1, f8, f8, i8_1, i8_1, b1_1, f8_1, f8, f8, f8, f8, f8_2, *CHAIN_SIG)
