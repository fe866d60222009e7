"""Compiled forward kinematics of one `Chain`: joint frames, tip pose, and the point and direction
Jacobians the IK and gaze kernels (`backend.engine.compiled.ik`, `.gaze`) build their ticks on.

The numpy references are `Chain.kinematics` / `Chain.fk` (backend/engine/kinematics.py); these kernels
do the same arithmetic in loops over the chain's few joints (m, 3 and 4x4 sized work, where numpy's
per-call overhead was the whole cost). Units: m and rad. A chain is passed as the arrays of
`chain_args` (see `CHAIN_SIG`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.compiled import b1, f8_1, f8_2, f8_3, i8_1

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
    out = np.empty((a.shape[0], b.shape[1]))
    _matmul_into(a, b, out)
    return out


@njit(cache=True)
def _matmul_into(a, b, out):
    """`_matmul` into `out` (a's rows, b's columns); `out` must not be `a` or `b`."""
    n, m, p = a.shape[0], a.shape[1], b.shape[1]
    for i in range(n):
        for j in range(p):
            s = 0.0
            for k in range(m):
                s += a[i, k] * b[k, j]
            out[i, j] = s


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
    _joint_positions_into(values, rows, offset, lower, upper, q)
    return q


@njit(cache=True)
def _joint_positions_into(values, rows, offset, lower, upper, q):
    """`_joint_positions` into `q` (the chain's joints,)."""
    for i in range(offset.shape[0]):
        s = 0.0
        for c in range(values.shape[0]):
            s += rows[i, c] * values[c]
        q[i] = min(max(s + offset[i], lower[i]), upper[i])
