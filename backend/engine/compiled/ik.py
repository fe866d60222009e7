"""The compiled tick of the IK block: damped least squares on the chain's Jacobian
(`backend.engine.compiled.kinematics`), with a pull back toward the start within the task's null space.

The numpy reference is `InverseKinematics.transform` (backend/engine/blocks/ik.py). Units: m and rad.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.compiled import b1, b1_1, f8, f8_1, f8_2, i8, i8_1
from backend.engine.compiled.kinematics import (
    CHAIN_SIG,
    _joint_positions_into,
    _kinematics_into,
    _matmul_into,
)


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


def ik_workspace(n_joints: int, n_var: int, n_moving: int, n_select: int) -> np.ndarray:
    """The scratch one IK kernel call works in (`_ik_tick` carves it, in this order): joints q0, q; per
    variable ch, lo, hi, moved, back, dq, blocked and the Jacobian (3, nv) and pseudo-inverse (nv, 3);
    the forward kinematics' frames (n_moving, 4, 4), four 4x4 and the Jacobians (3, n_moving) and
    mapped (3, n_select) twice; err, point, d, jm (3,); two 3x3. Made once per configuration, so a tick
    allocates nothing."""
    return np.zeros(2 * n_joints + 13 * n_var + 22 * n_moving + 6 * n_select + 4 * 16 + 4 * 3 + 2 * 9)


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
    ws,
):
    """One IK tick (see `_ik_tick`) with its constant vectors packed by `ik_constants`, working in `ws`
    (`ik_workspace`)."""
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
        ws,
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
    ws,
):
    """One IK tick (see `InverseKinematics.transform`): the stage-1 pose `values` (C,) takes the frame's
    set channels (in place); from it and last tick's correction `delta` (updated in place), solve
    toward `target` and write the frame with the moved joint DoFs, blended by `weight`, to `out`
    (its mask, with `add_mask`, to `out_mask`). Every scratch array is a view of `ws` (`ik_workspace`)."""
    for c in range(values.shape[0]):
        if frame_mask[c]:
            values[c] = frame_values[c]
        out[c] = frame_values[c]
        out_mask[c] = frame_mask[c] or add_mask[c]
    nv, nj, m, ns = var.shape[0], j_off.shape[0], pre.shape[0], select.shape[1]
    q0, q = ws[:nj], ws[nj : 2 * nj]
    o = 2 * nj
    ch, lo, hi = ws[o : o + nv], ws[o + nv : o + 2 * nv], ws[o + 2 * nv : o + 3 * nv]
    moved, back, dq = ws[o + 3 * nv : o + 4 * nv], ws[o + 4 * nv : o + 5 * nv], ws[o + 5 * nv : o + 6 * nv]
    blocked = ws[o + 6 * nv : o + 7 * nv]  # 1.0: the joint's step would push past a limit
    o += 7 * nv
    jac, pinv = ws[o : o + 3 * nv].reshape((3, nv)), ws[o + 3 * nv : o + 6 * nv].reshape((nv, 3))
    o += 6 * nv
    frames = ws[o : o + 16 * m].reshape((m, 4, 4))
    o += 16 * m
    tip, t4 = ws[o : o + 16].reshape((4, 4)), ws[o + 16 : o + 32].reshape((4, 4))
    motion, tmp = ws[o + 32 : o + 48].reshape((4, 4)), ws[o + 48 : o + 64].reshape((4, 4))
    o += 64
    jp_m, jd_m = ws[o : o + 3 * m].reshape((3, m)), ws[o + 3 * m : o + 6 * m].reshape((3, m))
    o += 6 * m
    jp_s, jd_s = ws[o : o + 3 * ns].reshape((3, ns)), ws[o + 3 * ns : o + 6 * ns].reshape((3, ns))
    o += 6 * ns
    err, point, d, jm = ws[o : o + 3], ws[o + 3 : o + 6], ws[o + 6 : o + 9], ws[o + 9 : o + 12]
    o += 12
    a3, inv3 = ws[o : o + 9].reshape((3, 3)), ws[o + 9 : o + 18].reshape((3, 3))
    if o + 18 > ws.shape[0]:  # slices stop at the end: a short workspace would be written past it
        raise ValueError("the IK workspace is smaller than this chain needs (ik_workspace)")
    _joint_positions_into(values, j_rows, j_off, lower, upper, q0)
    q[:] = q0
    for j in range(nv):
        v = var[j]
        ch[j] = values[var_ch[j]]
        lo[j] = max(lower[v], q0[v] + dof_lo[j] - ch[j])
        hi[j] = min(upper[v], q0[v] + dof_hi[j] - ch[j])
        q[v] = min(max(q0[v] + delta[j], lo[j]), hi[j])
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
            _matmul_into(jp_m, select, jp_s)
            _matmul_into(jd_m, select, jd_s)
            jp, jd = jp_s, jd_s
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
            stop = (qv <= lo[j] and dq[j] < 0.0) or (qv >= hi[j] and dq[j] > 0.0)
            blocked[j] = 1.0 if stop else 0.0
            any_blocked = any_blocked or stop
        if any_blocked:
            for j in range(nv):
                if blocked[j] != 0.0:
                    jac[0, j] = jac[1, j] = jac[2, j] = 0.0
            _dls_step_into(jac, err, moved, size, lam2, null_gain, null_range, a3, inv3, pinv, dq, jm, back)
            for j in range(nv):
                if blocked[j] != 0.0:
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
    f8_1,  # the workspace (`ik_workspace`)
)
