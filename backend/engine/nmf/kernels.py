"""The NMF's compiled kernels (numba): one filter step over a structure-of-arrays buffer, and a loop
over a whole trajectory.

- A one-pass loop for a few DoFs (`_step_one_pass`), and for more DoFs simple passes over the DoFs that
  the compiler turns into SIMD code (`_step_passes`, which also handles coupled groups).
- `tanh` and H's power are our own branch-free implementations (`fast_math`: `_tanh` within 4 ulp of
  libm's; `_pow` within 2e-13 relative; see tests) because libm's cannot be vectorised; their numpy
  twins in `reference.py` perform the same operations with the same constants (defined in
  `fast_math`). Ω's power (only near position limits) stays libm's.
- Divisions by constants are multiplications by their inverses computed once in
  `params.stage_params` (1/dt = rate, 2/k, 1/(1-rho), 1/alpha).
- `_entry_points` gives the compiled steps without the dispatcher's type resolution.
"""

from __future__ import annotations

import math
from typing import Any

from numba import types as nt

# The numba import and the branch-free tanh and pow live in `fast_math`.
from backend.engine.nmf.fast_math import _pow, _tanh, njit
from backend.engine.nmf.params import (  # the buffer's rows and the overflow caps
    _ACC,
    _BYPASS,
    _CENTER,
    _EXPO,
    _GID,
    _HASPOS,
    _HI,
    _HMIX,
    _IALPHA,
    _IHA,
    _IHJ,
    _IHV,
    _INIT,
    _IOMR,
    _JERK,
    _KA,
    _KJ,
    _KV,
    _LO,
    _MEMBER,
    _SP,
    _TWOB,
    _VEL,
    _WG1,
    _WG2,
    _WN,
    _WT,
    _WU,
    _WV,
    _X,
    H_BASE_MAX,
    V_CLAMP,
)

# ------------------------------------------------------------------------------------------------
# Compiled kernels (numba). Scalar helpers are inlined; loops run over DoFs inside compiled code.
# error_model="numpy": a division by zero gives inf instead of raising, which lets loops vectorise
# (no division here can be by zero: dt > 0, k/2 > 0, 1 - rho >= 0.001, alpha > 0, m > 0 checked).
# ------------------------------------------------------------------------------------------------


@njit(cache=True, error_model="numpy")
def _lim(u, k, inv_h, hard):
    """lam for one value: the tanh limiter (headroom k/2; inv_h = 2/k) or the hard clip at k."""
    if hard:
        return min(max(u, -k), k)
    return (0.5 * k) * _tanh(u * inv_h)


@njit(cache=True, error_model="numpy")
def _induced(s, x, rate):
    """(s - x)/dt, capped at +-V_CLAMP (only ever reached when s - x overflows the float range)."""
    return min(max((s - x) * rate, -V_CLAMP), V_CLAMP)


@njit(cache=True, error_model="numpy")
def _omega1(v, x, center, inv_alpha, twob):
    if (x > center and v > 0.0) or (x < center and v < 0.0):
        r = min(abs(x - center) * inv_alpha, 1.0)
        return v * (1.0 - r**twob)
    return v


@njit(cache=True, inline="always", error_model="numpy")
def _h_arg(speed, inv_omr, expo):
    """(min(|v|/(1-rho), cap))^(1-sigma) - pi: the argument of H's tanh (exponents 0 and 1 exact)."""
    b = min(speed * inv_omr, H_BASE_MAX)
    pw = _pow(b, expo)  # computed always and selected: branch-free, so the loop vectorises
    p = 1.0 if expo == 0.0 else (b if expo == 1.0 else pw)
    return p - math.pi


@njit(cache=True, error_model="numpy")
def _advance(u, x, vel, acc, i, buf, dt, rate, order, hard):
    """Limiters and integration for DoF i with target velocity u: (x', vel', acc', reported jerk)."""
    if order == 1:
        w = _lim(u, buf[_KV, i], buf[_IHV, i], hard)
        a = (w - vel) * rate
    elif order == 2:
        a = _lim((u - vel) * rate, buf[_KA, i], buf[_IHA, i], hard)
        w = _lim(vel + a * dt, buf[_KV, i], buf[_IHV, i], hard)
        a = (w - vel) * rate
    else:
        j = _lim(((u - vel) * rate - acc) * rate, buf[_KJ, i], buf[_IHJ, i], hard)
        a = _lim(acc + j * dt, buf[_KA, i], buf[_IHA, i], hard)
        w = _lim(vel + a * dt, buf[_KV, i], buf[_IHV, i], hard)
    lo = buf[_LO, i]
    hi = buf[_HI, i]
    xn = x + w * dt
    # Leaving [lo, hi] clips x' and zeroes vel', acc'; lo/hi are -inf/+inf without position limits.
    inside = lo <= xn and xn <= hi
    xn = min(max(xn, lo), hi)
    w = w if inside else 0.0
    a = a if inside else 0.0
    return xn, w, a, (a - acc) * rate


@njit(cache=True, error_model="numpy")
def _advance_all(buf, n, dt, rate, order, hard):
    """`_advance` over all uncoupled DoFs, as passes that each write one array (the compiler
    vectorises a loop only when few arrays may alias), with branch-free selects. Called with literal
    order/hard so each instance is specialised. The same operations as `_advance`."""
    u = buf[_WV]
    x = buf[_X]
    vel = buf[_VEL]
    acc = buf[_ACC]
    jerk = buf[_JERK]
    w = buf[_WU]
    a = buf[_WT]
    kv = buf[_KV]
    ka = buf[_KA]
    kj = buf[_KJ]
    ihv = buf[_IHV]
    iha = buf[_IHA]
    ihj = buf[_IHJ]
    lo = buf[_LO]
    hi = buf[_HI]
    if order == 1:
        for i in range(n):
            w[i] = _lim(u[i], kv[i], ihv[i], hard)
        for i in range(n):
            a[i] = (w[i] - vel[i]) * rate
    elif order == 2:
        for i in range(n):
            a[i] = _lim((u[i] - vel[i]) * rate, ka[i], iha[i], hard)
        for i in range(n):
            w[i] = _lim(vel[i] + a[i] * dt, kv[i], ihv[i], hard)
        for i in range(n):
            a[i] = (w[i] - vel[i]) * rate
    else:
        for i in range(n):
            j = _lim(((u[i] - vel[i]) * rate - acc[i]) * rate, kj[i], ihj[i], hard)
            a[i] = _lim(acc[i] + j * dt, ka[i], iha[i], hard)
        for i in range(n):
            w[i] = _lim(vel[i] + a[i] * dt, kv[i], ihv[i], hard)
    for i in range(n):
        jerk[i] = ((a[i] if lo[i] <= x[i] + w[i] * dt <= hi[i] else 0.0) - acc[i]) * rate
    for i in range(n):
        acc[i] = a[i] if lo[i] <= x[i] + w[i] * dt <= hi[i] else 0.0
    for i in range(n):
        vel[i] = w[i] if lo[i] <= x[i] + w[i] * dt <= hi[i] else 0.0
    for i in range(n):
        x[i] = min(max(x[i] + w[i] * dt, lo[i]), hi[i])


@njit(cache=True, error_model="numpy")
def _ingest(sp_in, buf, n):
    """Store new set-points (NaN = hold); a DoF's first set-point initialises its position."""
    for i in range(n):
        s = sp_in[i]
        if s == s:
            buf[_SP, i] = s
            if buf[_INIT, i] == 0.0:
                buf[_X, i] = s
                buf[_INIT, i] = 1.0


@njit(cache=True, error_model="numpy")
def _step_one_pass(sp_in, buf, cfg):
    """The step for a few uncoupled DoFs, one DoF at a time (the least overhead at 1 DoF)."""
    dt = cfg[0]
    order = int(cfg[1])
    hard = cfg[2] != 0.0
    rate = cfg[7]
    n = sp_in.shape[0]
    _ingest(sp_in, buf, n)
    for i in range(n):
        x = buf[_X, i]
        v = _induced(buf[_SP, i], x, rate)
        if buf[_HASPOS, i] != 0.0:
            v = _omega1(v, x, buf[_CENTER, i], buf[_IALPHA, i], buf[_TWOB, i])
        if buf[_BYPASS, i] == 0.0:  # (v * (g * 1 + 0) here; bypassed: v * (g * 0 + 1) = v, as in the passes)
            t = _h_arg(abs(v), buf[_IOMR, i], buf[_EXPO, i])
            v = v * ((0.5 * (_tanh(t) + 1.0)) * buf[_HMIX, i] + buf[_BYPASS, i])
        xn, w, a, j = _advance(v, x, buf[_VEL, i], buf[_ACC, i], i, buf, dt, rate, order, hard)
        buf[_X, i] = xn
        buf[_VEL, i] = w
        buf[_ACC, i] = a
        buf[_JERK, i] = j


@njit(cache=True, error_model="numpy")
def _norms(vec, buf, n, n_groups):
    """|vec_i|, or for members of a coupled group the group's Euclidean norm (scaled: no overflow),
    into the scratch row _WN."""
    nrm = buf[_WN]
    gmax = buf[_WG1]
    gsum = buf[_WG2]
    gid = buf[_GID]
    member = buf[_MEMBER]
    for g in range(n_groups):
        gmax[g] = 0.0
        gsum[g] = 0.0
    for i in range(n):
        if member[i] != 0.0:
            g = int(gid[i])
            gmax[g] = max(gmax[g], abs(vec[i]))
    for i in range(n):
        if member[i] != 0.0:
            g = int(gid[i])
            if gmax[g] > 0.0:
                q = vec[i] / gmax[g]
                gsum[g] += q * q
    for i in range(n):
        if member[i] != 0.0:
            g = int(gid[i])
            nrm[i] = gmax[g] * math.sqrt(gsum[g])
        else:
            nrm[i] = abs(vec[i])


@njit(cache=True, error_model="numpy")
def _limit_groups(vec, krow, ihrow, hard, buf, n, n_groups):
    """lam in place: per DoF, or on each coupled group's norm with the vector scaled proportionally."""
    _norms(vec, buf, n, n_groups)
    nrm = buf[_WN]
    member = buf[_MEMBER]
    for i in range(n):
        if member[i] != 0.0:
            m = nrm[i]
            if m > 0.0:
                vec[i] = vec[i] * (_lim(m, krow[i], ihrow[i], hard) / m)
        else:
            vec[i] = _lim(vec[i], krow[i], ihrow[i], hard)


@njit(cache=True, error_model="numpy")
def _step_passes(sp_in, buf, cfg):
    """The step in passes over all DoFs (vectorised by the compiler); handles coupled groups."""
    dt = cfg[0]
    order = int(cfg[1])
    hard = cfg[2] != 0.0
    n_groups = int(cfg[3])
    grouped = cfg[4] != 0.0
    any_pos = cfg[5] != 0.0
    all_bypass = cfg[6] != 0.0
    rate = cfg[7]
    n = sp_in.shape[0]
    x = buf[_X]
    vel = buf[_VEL]
    acc = buf[_ACC]
    jerk = buf[_JERK]
    sp = buf[_SP]
    v = buf[_WV]
    t = buf[_WT]
    _ingest(sp_in, buf, n)
    for i in range(n):
        v[i] = _induced(sp[i], x[i], rate)
    if any_pos:
        haspos = buf[_HASPOS]
        center = buf[_CENTER]
        ialpha = buf[_IALPHA]
        twob = buf[_TWOB]
        for i in range(n):
            if haspos[i] != 0.0:
                v[i] = _omega1(v[i], x[i], center[i], ialpha[i], twob[i])
    if not all_bypass:
        iomr = buf[_IOMR]
        expo = buf[_EXPO]
        bypass = buf[_BYPASS]  # 1.0 or 0.0
        hmix = buf[_HMIX]  # 1 - bypass
        if grouped:
            _norms(v, buf, n, n_groups)
            nrm = buf[_WN]
            for i in range(n):
                t[i] = _h_arg(nrm[i], iomr[i], expo[i])
        else:
            for i in range(n):
                t[i] = _h_arg(abs(v[i]), iomr[i], expo[i])
        for i in range(n):  # branch-free: u = v g, or v where bypassed (v (g 0 + 1) = v exactly)
            v[i] = v[i] * ((0.5 * (_tanh(t[i]) + 1.0)) * hmix[i] + bypass[i])
    if not grouped:
        if hard:
            if order == 1:
                _advance_all(buf, n, dt, rate, 1, True)
            elif order == 2:
                _advance_all(buf, n, dt, rate, 2, True)
            else:
                _advance_all(buf, n, dt, rate, 3, True)
        else:
            if order == 1:
                _advance_all(buf, n, dt, rate, 1, False)
            elif order == 2:
                _advance_all(buf, n, dt, rate, 2, False)
            else:
                _advance_all(buf, n, dt, rate, 3, False)
        return
    # Coupled groups: every lam acts on group norms, so each stage is a pass over all DoFs.
    kv = buf[_KV]
    ka = buf[_KA]
    kj = buf[_KJ]
    ihv = buf[_IHV]
    iha = buf[_IHA]
    ihj = buf[_IHJ]
    lo = buf[_LO]
    hi = buf[_HI]
    w = buf[_WU]
    a = t
    if order == 1:
        for i in range(n):
            w[i] = v[i]
        _limit_groups(w, kv, ihv, hard, buf, n, n_groups)
        for i in range(n):
            a[i] = (w[i] - vel[i]) * rate
    elif order == 2:
        for i in range(n):
            a[i] = (v[i] - vel[i]) * rate
        _limit_groups(a, ka, iha, hard, buf, n, n_groups)
        for i in range(n):
            w[i] = vel[i] + a[i] * dt
        _limit_groups(w, kv, ihv, hard, buf, n, n_groups)
        for i in range(n):
            a[i] = (w[i] - vel[i]) * rate
    else:
        for i in range(n):
            a[i] = ((v[i] - vel[i]) * rate - acc[i]) * rate
        _limit_groups(a, kj, ihj, hard, buf, n, n_groups)
        for i in range(n):
            a[i] = acc[i] + a[i] * dt
        _limit_groups(a, ka, iha, hard, buf, n, n_groups)
        for i in range(n):
            w[i] = vel[i] + a[i] * dt
        _limit_groups(w, kv, ihv, hard, buf, n, n_groups)
    for i in range(n):
        xn = x[i] + w[i] * dt
        inside = lo[i] <= xn and xn <= hi[i]
        xn = min(max(xn, lo[i]), hi[i])
        wi = w[i] if inside else 0.0
        ai = a[i] if inside else 0.0
        jerk[i] = (ai - acc[i]) * rate
        x[i] = xn
        vel[i] = wi
        acc[i] = ai


@njit(cache=True, error_model="numpy")
def _run_compiled(sps, buf, cfg, one_pass, out):
    """Filter a whole trajectory: sps (T, n); out (4, T, n) position, velocity, acceleration, jerk."""
    n = sps.shape[1]
    for k in range(sps.shape[0]):
        if one_pass:
            _step_one_pass(sps[k], buf, cfg)
        else:
            _step_passes(sps[k], buf, cfg)
        for i in range(n):
            out[0, k, i] = buf[_X, i]
            out[1, k, i] = buf[_VEL, i]
            out[2, k, i] = buf[_ACC, i]
            out[3, k, i] = buf[_JERK, i]


def _entry_points() -> tuple[Any, Any]:
    """The compiled steps for C-contiguous float64 arrays, callable without the dispatcher's type
    resolution (which is most of the cost of a 1-DoF step)."""

    sig = (nt.float64[::1], nt.float64[:, ::1], nt.float64[::1])
    out = []
    for disp in (_step_passes, _step_one_pass):
        disp.compile(sig)
        out.append(disp.overloads[sig].entry_point)
    return out[0], out[1]
