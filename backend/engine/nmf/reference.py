"""The NMF in numpy: the spec's formulas as building blocks (lam, Ω, H; used by the figures and the
hand-computed tests), numpy twins of the kernels' tanh and power, and `_reference_step`, the same
arithmetic as the compiled kernels vectorised over DoFs (the tests' oracle; the fallback without numba).
"""

from __future__ import annotations

import math

import numpy as np

from backend.engine.nmf.fast_math import (  # the constants the compiled tanh/pow use, so the twins match
    _C2,
    _C3,
    _C4,
    _C5,
    _C6,
    _C7,
    _C8,
    _C9,
    _C10,
    _C11,
    _C12,
    _C13,
    _EXP_HI,
    _EXP_LO,
    _INV_LN2,
    _L3,
    _L5,
    _L7,
    _L9,
    _L11,
    _L13,
    _L15,
    _L17,
    _L19,
    _L21,
    _L23,
    _LN2_HI,
    _LN2_LO,
    _ROUND,
    _SQRT2,
    _TANH_CAP,
)
from backend.engine.nmf.params import (
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
    _X,
    H_BASE_MAX,
    RHO_MAX,
    V_CLAMP,
)


def tanh_np(x: np.ndarray) -> np.ndarray:
    """numpy twin of `_tanh` (the same operations in the same order, so the same bits)."""
    x = np.asarray(x, dtype=float)
    a = np.minimum(np.abs(x), _TANH_CAP)
    y = a + a
    k = (y * _INV_LN2 + _ROUND) - _ROUND
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = r * (
        1.0
        + r
        * (
            _C2
            + r
            * (
                _C3
                + r
                * (
                    _C4
                    + r
                    * (
                        _C5
                        + r
                        * (
                            _C6
                            + r
                            * (_C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))
                        )
                    )
                )
            )
        )
    )
    s = np.ldexp(1.0, k.astype(np.int64))
    em1 = s * p + (s - 1.0)
    t = em1 / (em1 + 2.0)
    return np.where(x >= 0.0, t, -t)


def pow_np(b: np.ndarray, e: np.ndarray) -> np.ndarray:
    """numpy twin of `_pow` (same operations, same bits)."""
    b = np.asarray(b, dtype=float)
    e = np.asarray(e, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        m, ex = np.frexp(b)  # b = m 2**ex, m in [0.5, 1): the same (m, E) as the bit reading above
        m = m * 2.0
        ex = ex.astype(float) - 1.0
        big = m > _SQRT2
        m = np.where(big, m * 0.5, m)
        ex = ex + np.where(big, 1.0, 0.0)
        f = (m - 1.0) / (m + 1.0)
        f2 = f * f
        q = f2 * (
            _L3
            + f2
            * (
                _L5
                + f2
                * (
                    _L7
                    + f2
                    * (
                        _L9
                        + f2
                        * (
                            _L11
                            + f2 * (_L13 + f2 * (_L15 + f2 * (_L17 + f2 * (_L19 + f2 * (_L21 + f2 * _L23)))))
                        )
                    )
                )
            )
        )
        lnb = ex * _LN2_HI + (ex * _LN2_LO + (f + f) * (1.0 + q))
        y = np.minimum(np.maximum(e * lnb, _EXP_LO), _EXP_HI)
        k = (y * _INV_LN2 + _ROUND) - _ROUND
        r = (y - k * _LN2_HI) - k * _LN2_LO
        p = r * (
            1.0
            + r
            * (
                _C2
                + r
                * (
                    _C3
                    + r
                    * (
                        _C4
                        + r
                        * (
                            _C5
                            + r
                            * (
                                _C6
                                + r
                                * (
                                    _C7
                                    + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13)))))
                                )
                            )
                        )
                    )
                )
            )
        )
        s = np.ldexp(1.0, k.astype(np.int64))
        out = s * p + s
    return np.where(b > 0.0, out, 0.0)


# ------------------------------------------------------------------------------------------------
# Building blocks (numpy, the spec's formulas; used by the figures and the hand-computed tests)
# ------------------------------------------------------------------------------------------------


def lam(u: np.ndarray | float, k: np.ndarray | float, hard: bool = False) -> np.ndarray:
    """The limiter: `k/2 tanh(u/(k/2))` (never reaches k/2) or, hard, `clip(u, -k, k)`."""
    u = np.asarray(u, dtype=float)
    if hard:
        return np.clip(u, -k, k)
    h = np.asarray(k, dtype=float) / 2.0
    return h * np.tanh(u / h)


def omega(v: np.ndarray | float, x: np.ndarray | float, pmin: float, pmax: float, beta: float) -> np.ndarray:
    """Position saturation Ω: the induced velocity fades to 0 when moving toward a position limit.

    The power is taken of |x - centre|/alpha (an even power in the paper; beta need not be an integer).
    """
    v = np.asarray(v, dtype=float)
    x = np.asarray(x, dtype=float)
    alpha = (pmax - pmin) / 2.0
    center = pmin + alpha
    r = np.minimum(np.abs((x - center) / alpha), 1.0)
    toward = ((x > center) & (v > 0)) | ((x < center) & (v < 0))
    return np.where(toward, v * (1.0 - r ** (2.0 * beta)), v)


def h_gain(speed: np.ndarray | float, sigma: np.ndarray | float, rho: np.ndarray | float) -> np.ndarray:
    """H's gain g(|v|) so that H(v) = v g(|v|): `(tanh((|v|/(1-rho))^(1-sigma) - pi) + 1) / 2`, in [0, 1].

    Finite for every sigma, rho in [0, 1] and finite |v| (0^0 = 1 at sigma = 1; rho clamped to 0.999).
    """
    speed = np.abs(np.asarray(speed, dtype=float))
    rho = np.minimum(np.asarray(rho, dtype=float), RHO_MAX)
    base = speed / (1.0 - rho)
    # tanh saturates long before the power overflows: cap the argument to keep it finite.
    powered = np.power(np.minimum(base, H_BASE_MAX), 1.0 - np.asarray(sigma, dtype=float))
    return 0.5 * (np.tanh(powered - math.pi) + 1.0)


def stabilise(v: np.ndarray | float, sigma: float, rho: float) -> np.ndarray:
    """The stabilisation (transfer) function H(v) = v/2 (tanh((|v|/(1-rho))^(1-sigma) - pi) + 1)."""
    v = np.asarray(v, dtype=float)
    return v * h_gain(np.abs(v), sigma, rho)


# ------------------------------------------------------------------------------------------------
# The numpy reference: the same arithmetic, vectorised over DoFs (tests; fallback without numba)
# ------------------------------------------------------------------------------------------------


def _lim_np(u: np.ndarray, k: np.ndarray, inv_h: np.ndarray, hard: bool) -> np.ndarray:
    if hard:
        return np.minimum(np.maximum(u, -k), k)
    return (0.5 * k) * tanh_np(u * inv_h)


def _norms_np(vec: np.ndarray, buf: np.ndarray, n_groups: int) -> np.ndarray:
    member = buf[_MEMBER] != 0.0
    gid = buf[_GID].astype(np.int64)
    out = np.abs(vec)
    if member.any():
        gmax = np.zeros(n_groups)
        np.maximum.at(gmax, gid[member], np.abs(vec[member]))
        scale = gmax[gid]
        q = np.divide(vec, scale, out=np.zeros_like(vec), where=member & (scale > 0.0))
        # bincount adds in index order, like the compiled loop
        gsum = np.bincount(gid[member], weights=(q * q)[member], minlength=n_groups)
        out = np.where(member, gmax[gid] * np.sqrt(gsum[gid]), out)
    return out


def _limit_groups_np(
    vec: np.ndarray, k: np.ndarray, inv_h: np.ndarray, hard: bool, buf: np.ndarray, n_groups: int
) -> np.ndarray:
    member = buf[_MEMBER] != 0.0
    if not member.any():
        return _lim_np(vec, k, inv_h, hard)
    m = _norms_np(vec, buf, n_groups)
    safe = np.where(m > 0.0, m, 1.0)
    scaled = np.where(m > 0.0, vec * (_lim_np(m, k, inv_h, hard) / safe), vec)
    return np.where(member, scaled, _lim_np(vec, k, inv_h, hard))


def _reference_step(sp_in: np.ndarray, buf: np.ndarray, cfg: np.ndarray) -> None:
    """One step of the filter in numpy (state rows of `buf` updated in place)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # inf/inf never reaches an output
        _reference_step_body(sp_in, buf, cfg)


def _reference_step_body(sp_in: np.ndarray, buf: np.ndarray, cfg: np.ndarray) -> None:
    dt, order, hard, rate = cfg[0], int(cfg[1]), bool(cfg[2]), cfg[7]
    n_groups, any_pos, all_bypass = int(cfg[3]), bool(cfg[5]), bool(cfg[6])
    new = ~np.isnan(sp_in)
    buf[_SP, new] = sp_in[new]
    first = new & (buf[_INIT] == 0.0)
    buf[_X, first] = sp_in[first]
    buf[_INIT, first] = 1.0
    x, vel, acc = buf[_X], buf[_VEL], buf[_ACC]
    v = np.minimum(np.maximum((buf[_SP] - x) * rate, -V_CLAMP), V_CLAMP)
    if any_pos:
        c = buf[_CENTER]
        toward = (buf[_HASPOS] != 0.0) & (((x > c) & (v > 0.0)) | ((x < c) & (v < 0.0)))
        r = np.minimum(np.abs(x - c) * buf[_IALPHA], 1.0)
        v = np.where(toward, v * (1.0 - r ** buf[_TWOB]), v)
    if not all_bypass:
        b = np.minimum(_norms_np(v, buf, n_groups) * buf[_IOMR], H_BASE_MAX)
        e = buf[_EXPO]
        p = np.where(e == 0.0, 1.0, np.where(e == 1.0, b, pow_np(b, e)))
        v = v * ((0.5 * (tanh_np(p - math.pi) + 1.0)) * buf[_HMIX] + buf[_BYPASS])
    kv, ka, kj, ihv, iha, ihj = buf[_KV], buf[_KA], buf[_KJ], buf[_IHV], buf[_IHA], buf[_IHJ]
    if order == 1:
        w = _limit_groups_np(v, kv, ihv, hard, buf, n_groups)
        a = (w - vel) * rate
    elif order == 2:
        a = _limit_groups_np((v - vel) * rate, ka, iha, hard, buf, n_groups)
        w = _limit_groups_np(vel + a * dt, kv, ihv, hard, buf, n_groups)
        a = (w - vel) * rate
    else:
        j = _limit_groups_np(((v - vel) * rate - acc) * rate, kj, ihj, hard, buf, n_groups)
        a = _limit_groups_np(acc + j * dt, ka, iha, hard, buf, n_groups)
        w = _limit_groups_np(vel + a * dt, kv, ihv, hard, buf, n_groups)
    xn = x + w * dt
    inside = (buf[_LO] <= xn) & (xn <= buf[_HI])
    xn = np.minimum(np.maximum(xn, buf[_LO]), buf[_HI])
    w = np.where(inside, w, 0.0)
    a = np.where(inside, a, 0.0)
    buf[_JERK] = (a - acc) * rate
    buf[_X] = xn
    buf[_VEL] = w
    buf[_ACC] = a
