"""The Nutty Motion Filter (NMF): stepped, CGI-style set-points in; motor-safe motion out.

Implements the exact discrete-time reading in `shared/specs/nmf.md`:

    v  = Omega((s - x)/dt, x)         induced velocity, saturated near the position limits
    u  = H(v)                         target velocity shaped by sigma (smoothness), rho (responsiveness)
    order 1: vel' = lam(u, V)
    order 2: acc' = lam((u - vel)/dt, A);                  vel' = lam(vel + acc' dt, V)
    order 3: jerk = lam(((u - vel)/dt - acc)/dt, J);       acc' = lam(acc + jerk dt, A)
                                                           vel' = lam(vel + acc' dt, V)
    x' = x + vel' dt;  leaving [Pmin, Pmax] clips x' and zeroes vel', acc'

with `lam(u, k) = k/2 tanh(u / (k/2))` (tanh limiter, never reaches k/2) or `clip(u, -k, k)` (hard).
DoFs declared as a group (e.g. a base's x and y) are limited by their vector norm.

Every parameter is a scalar or a per-DoF array, so one filter serves a whole robot.

Implementation
- State and parameters are structure-of-arrays rows of one float64 buffer. The hot path is a
  numba-compiled kernel: a one-pass loop for a few DoFs, and for more DoFs simple passes over the
  DoFs that the compiler turns into SIMD code. `tanh` and H's power are our own branch-free
  implementations (`_tanh` within 4 ulp of libm's; `_pow` within 2e-13 relative; see tests) because
  libm's cannot be vectorised. Ω's power (only near position limits) stays libm's.
- `_reference_step` is a pure-numpy implementation of the same arithmetic, vectorised over DoFs. The
  tests check the compiled kernels against it bit for bit; it is the fallback when numba is missing.
- Divisions by constants are multiplications by their inverses computed once in `set_params`
  (1/dt = rate, 2/k, 1/(1-rho), 1/alpha): a rounding difference of at most an ulp from the printed
  formulas, for several times fewer divisions in the hot loop.
- Overflow guards that change no output: the induced velocity is clamped to +-1e290 (every limiter
  has saturated long before), H's base to 1e12 (tanh has saturated), group norms are computed
  scaled. With limits <= 1e100 and rates in [1e-3, 1e6] Hz no intermediate value can overflow, so
  the filter never produces NaN or inf for finite set-points.

Known limits of the spec's guarantees (found by property testing; the filter is left exactly as
specified): the spec bounds the *output's* finite differences (|v| <= V/2, |a| <= A, |j| <= J with
tanh). The velocity and acceleration bounds follow from the equations (each limiter's compression is
at most the next derivative's headroom) and held in every case tried. The jerk bound does not: the
velocity limiter compresses vel + acc' dt toward 0 by an amount that changes with the velocity, and
that change is not charged to the jerk budget. It matters when one sample's jerk budget is small
against A, i.e. q = J dt / A is small. Measured over 20 000 random cases each (V 0.5-200, A 2-20 V,
30-500 Hz, any sigma/rho, arbitrary steps): worst output jerk / J = 0.86 for q >= 0.2, 0.95 for
q >= 0.15, 1.08 at q = 0.1, 1.6 at q = 0.01. The paper's presets at 60 Hz have q = 1.2-1.7; at
500 Hz, 0.14-0.2. tests/test_nmf_properties.py asserts the exact bound for q >= 0.2 and keeps a
counterexample for q = 0.01.

Units: positions in the DoF's unit (rad, m), velocity limit V per s, acceleration A per s², jerk J
per s³; `rate` in Hz (samples per second).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

try:  # numba is a hard dependency in pyproject; the fallback keeps the filter usable without it
    from numba import njit

    from numba import types as _nt
    from numba.core.extending import intrinsic

    HAVE_NUMBA = True

    # Bit casts between float64 and int64 (free in machine code, and vectorisable): they build 2**k
    # from k's bits inside _tanh.
    @intrinsic
    def _f2i(typingctx, x):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(_nt.int64))

        return _nt.int64(_nt.float64), codegen

    @intrinsic
    def _i2f(typingctx, x):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(_nt.float64))

        return _nt.float64(_nt.int64), codegen

except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False

    def njit(*_args: Any, **_kw: Any):  # type: ignore[no-redef]
        return lambda fn: fn


RHO_MAX = 0.999  # the spec clamps rho to at most 0.999 (H divides by 1 - rho)
H_BASE_MAX = 1e12  # (|v|/(1-rho)) is capped here before the power: tanh(1e12**e - pi) has saturated
V_CLAMP = 1e290  # |induced velocity| cap: keeps (v/dt)/dt finite; every limiter saturated long before
LIMIT_MAX = 1e100  # largest accepted V, A, J (keeps reported derivatives finite at any accepted rate)
RATE_MIN, RATE_MAX = 1e-3, 1e6  # accepted output rates (Hz)
ONE_PASS_MAX_DOFS = 4  # the one-pass kernel wins only for a few DoFs (measured)
ORDERS = (1, 2, 3)
LIMITERS = ("tanh", "hard")

# Rows of the buffer: state, then parameters (some derived once in set_params), then scratch.
(_X, _VEL, _ACC, _JERK, _SP, _INIT,
 _KV, _KA, _KJ, _SIGMA, _RHO, _BETA, _BYPASS,
 _IHV, _IHA, _IHJ, _EXPO, _IOMR, _HASPOS, _LO, _HI, _CENTER, _IALPHA, _TWOB, _MEMBER, _GID, _HMIX,
 _WV, _WU, _WT, _WN, _WG1, _WG2) = range(33)
N_ROWS = 33
_STATE = slice(_X, _INIT + 1)
_PARAMS = slice(_KV, _HMIX + 1)
# Derived rows: _IHV/_IHA/_IHJ = 2/k (the limiters multiply by the inverse headroom), _EXPO = 1 - sigma,
# _IOMR = 1/(1 - min(rho, RHO_MAX)), _IALPHA = 1/alpha, _TWOB = 2 beta, _HMIX = 1 - bypass; divisions
# by constants become multiplications (a division costs several multiplications' time).
# cfg vector: dt, order, hard, n_groups, grouped, any_pos, all_bypass, rate
_CFG_LEN = 8


@dataclass(frozen=True)
class Preset:
    """One of the paper's example filters."""

    name: str
    meaning: str
    sigma: float
    rho: float
    vel_limit: float
    acc_limit: float
    jerk_limit: float
    bypass: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "meaning": self.meaning, "sigma": self.sigma, "rho": self.rho,
                "vel_limit": self.vel_limit, "acc_limit": self.acc_limit, "jerk_limit": self.jerk_limit,
                "bypass": self.bypass}


# W bypasses H, so its sigma/rho are unused; they are the constructor's defaults.
PRESETS: dict[str, Preset] = {
    "W": Preset("W", "regular (H bypassed)", 0.5, 0.5, 20.0, 100.0, 10000.0, bypass=True),
    "A": Preset("A", "slow & smooth", 1.0, 1.0, 20.0, 100.0, 10000.0),
    "B": Preset("B", "slow & vivid", 0.1, 0.0, 20.0, 100.0, 10000.0),
    "C": Preset("C", "fast & vivid", 0.1, 0.0, 90.0, 700.0, 50000.0),
    "D": Preset("D", "fast & smooth", 0.95, 1.0, 90.0, 700.0, 50000.0),
    "E": Preset("E", "fast & very smooth", 0.95, 0.2, 90.0, 700.0, 50000.0),
}
_PRESET_ALIASES = {"REGULAR": "W"}


def preset(name: str) -> Preset:
    """The preset called `name` (W, A-E, case-insensitive; "regular" is W)."""
    key = str(name).strip().upper()
    key = _PRESET_ALIASES.get(key, key)
    if key not in PRESETS:
        raise ValueError(f"unknown preset '{name}' (one of {', '.join(PRESETS)} or 'regular')")
    return PRESETS[key]


# ------------------------------------------------------------------------------------------------
# tanh, twice: a scalar version for the compiled kernels and a numpy twin (identical operations)
# ------------------------------------------------------------------------------------------------
# tanh(a) = expm1(2a) / (expm1(2a) + 2), with expm1 by Cody-Waite reduction 2a = k ln2 + r,
# |r| <= ln2/2, and a degree-13 Taylor polynomial for expm1(r) (truncation < 1e-17 relative).
# For |a| >= 20 the result rounds to exactly 1, so the argument is capped there (k <= 58).
_LN2_HI = 6.93147180369123816490e-01  # ln 2 with trailing zero bits: k * _LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e+00
_TANH_CAP = 20.0
_ROUND = 6755399441055744.0  # 1.5 * 2**52: adding it rounds to an integer held in the low bits
_ROUND_BITS = int(np.float64(_ROUND).view(np.int64))
_C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11, _C12, _C13 = (1.0 / math.factorial(k) for k in range(2, 14))


@njit(cache=True, error_model="numpy")
def _tanh(x):
    a = min(abs(x), _TANH_CAP)
    y = a + a
    kr = y * _INV_LN2 + _ROUND  # round to nearest without a call: vectorisable
    k = kr - _ROUND
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = r * (1.0 + r * (_C2 + r * (_C3 + r * (_C4 + r * (_C5 + r * (_C6 + r * (
        _C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))))))))
    s = _i2f(((_f2i(kr) - _ROUND_BITS) + 1023) << 52)  # 2**k (0 <= k <= 58) from k's bits, exact
    em1 = s * p + (s - 1.0)
    t = em1 / (em1 + 2.0)
    return t if x >= 0.0 else -t


def tanh_np(x: np.ndarray) -> np.ndarray:
    """numpy twin of `_tanh` (the same operations in the same order, so the same bits)."""
    x = np.asarray(x, dtype=float)
    a = np.minimum(np.abs(x), _TANH_CAP)
    y = a + a
    k = (y * _INV_LN2 + _ROUND) - _ROUND
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = r * (1.0 + r * (_C2 + r * (_C3 + r * (_C4 + r * (_C5 + r * (_C6 + r * (
        _C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))))))))
    s = np.ldexp(1.0, k.astype(np.int64))
    em1 = s * p + (s - 1.0)
    t = em1 / (em1 + 2.0)
    return np.where(x >= 0.0, t, -t)


# b**e for 0 <= b <= H_BASE_MAX and 0 < e < 1 (H's power), vectorisable: exp(e ln b) with ln b from
# b = m 2**E, m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh((m-1)/(m+1)) (series to f**23), and exp by the
# same reduction as in tanh. Relative error below 2e-13 (tested against libm's pow); H only uses the
# result inside tanh(p - pi), where that is far below the gain's own rounding.
_SQRT2 = 1.4142135623730951
_TWO600 = 2.0 ** 600
_TINY = 2.0 ** -500  # smaller b are scaled up by 2**600 first (exact) to read their exponent
_L3, _L5, _L7, _L9, _L11, _L13, _L15, _L17, _L19, _L21, _L23 = (1.0 / k for k in range(3, 24, 2))
_EXP_LO, _EXP_HI = -700.0, 28.0  # e ln b lies in [-inf, ln 1e12 = 27.6]; below -700, b**e < 1e-304


@njit(cache=True, inline="always", error_model="numpy")
def _pow(b, e):
    small = b < _TINY
    bs = b * _TWO600 if small else b
    bits = _f2i(bs)
    ebits = (bits & 0x7FF0000000000000) >> 52  # masked first: a non-negative shift, which SIMD has
    m = _i2f((bits & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)  # mantissa in [1, 2)
    ex = (_i2f(ebits | _ROUND_BITS) - _ROUND) - 1023.0  # the exponent, as a float
    big = m > _SQRT2
    m = m * 0.5 if big else m
    ex = ex + (1.0 if big else 0.0) - (600.0 if small else 0.0)
    f = (m - 1.0) / (m + 1.0)
    f2 = f * f
    q = f2 * (_L3 + f2 * (_L5 + f2 * (_L7 + f2 * (_L9 + f2 * (_L11 + f2 * (_L13 + f2 * (
        _L15 + f2 * (_L17 + f2 * (_L19 + f2 * (_L21 + f2 * _L23))))))))))
    lnb = ex * _LN2_HI + (ex * _LN2_LO + (f + f) * (1.0 + q))
    y = min(max(e * lnb, _EXP_LO), _EXP_HI)
    kr = y * _INV_LN2 + _ROUND
    k = kr - _ROUND
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = r * (1.0 + r * (_C2 + r * (_C3 + r * (_C4 + r * (_C5 + r * (_C6 + r * (
        _C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))))))))
    s = _i2f(((_f2i(kr) - _ROUND_BITS) + 1023) << 52)
    out = s * p + s
    return out if b > 0.0 else 0.0


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
        q = f2 * (_L3 + f2 * (_L5 + f2 * (_L7 + f2 * (_L9 + f2 * (_L11 + f2 * (_L13 + f2 * (
            _L15 + f2 * (_L17 + f2 * (_L19 + f2 * (_L21 + f2 * _L23))))))))))
        lnb = ex * _LN2_HI + (ex * _LN2_LO + (f + f) * (1.0 + q))
        y = np.minimum(np.maximum(e * lnb, _EXP_LO), _EXP_HI)
        k = (y * _INV_LN2 + _ROUND) - _ROUND
        r = (y - k * _LN2_HI) - k * _LN2_LO
        p = r * (1.0 + r * (_C2 + r * (_C3 + r * (_C4 + r * (_C5 + r * (_C6 + r * (
            _C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))))))))
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
        return v * (1.0 - r ** twob)
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


def _limit_groups_np(vec: np.ndarray, k: np.ndarray, inv_h: np.ndarray, hard: bool, buf: np.ndarray,
                     n_groups: int) -> np.ndarray:
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


def _entry_points() -> tuple[Any, Any]:
    """The compiled steps for C-contiguous float64 arrays, callable without the dispatcher's type
    resolution (which is most of the cost of a 1-DoF step)."""
    from numba import types as nt

    sig = (nt.float64[::1], nt.float64[:, ::1], nt.float64[::1])
    out = []
    for disp in (_step_passes, _step_one_pass):
        disp.compile(sig)
        out.append(disp.overloads[sig].entry_point)
    return out[0], out[1]


_ENTRY_POINTS: tuple[Any, Any] | None = None


# ------------------------------------------------------------------------------------------------
# Public API
# ------------------------------------------------------------------------------------------------


@dataclass
class FilterResult:
    """Output of `MotionFilter.run`: arrays (T, n) of position, velocity, acceleration and jerk."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray


def _per_dof(name: str, value: Any, n: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or one number per DoF, got {value!r}") from None
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have one value per DoF ({n}), got shape {arr.shape}")
    return arr.astype(float, copy=True)


def _check(name: str, arr: np.ndarray, ok: np.ndarray, rule: str) -> None:
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name} of DoF {i} must be {rule}, got {float(arr[i])!r}")


class MotionFilter:
    """The NMF over `n_dofs` DoFs at `rate` Hz (see the module doc for the equations).

    Parameters (each a scalar or a per-DoF array):
      order 1|2|3 (continuity: velocity, acceleration or jerk limited);
      sigma, rho in [0, 1] (smoothness, responsiveness);
      vel_limit, acc_limit, jerk_limit in (0, 1e100] (units per s, s², s³; defaults: preset W's
        20, 100, 10000). With the tanh limiter the output's velocity stays below vel_limit/2;
      limiter "tanh" | "hard"; bypass (H replaced by identity: the paper's regular filter W);
      pmin < pmax: position limits (both or neither; a DoF with an infinite bound gets no Ω and is
        clipped only at its finite bound); beta >= 1: Ω's exponent (default 5);
      x0: initial positions (default: each DoF's first set-point; until a DoF receives one it outputs
        0, or its x0, at rest); groups: lists of DoF indices limited together by vector norm (their
        limits, sigma, rho and bypass must be equal).
    `rate` is the output rate in Hz, in [1e-3, 1e6]. `use_numba=False` selects the numpy reference.
    """

    def __init__(self, n_dofs: int, rate: float, order: int = 3, sigma: Any = 0.5, rho: Any = 0.5,
                 vel_limit: Any = 20.0, acc_limit: Any = 100.0, jerk_limit: Any = 10000.0,
                 limiter: str = "tanh", bypass: Any = False, pmin: Any = None, pmax: Any = None,
                 beta: Any = 5.0, x0: Any = None, groups: Sequence[Sequence[int]] | None = None,
                 use_numba: bool = True):
        if isinstance(n_dofs, bool) or not isinstance(n_dofs, numbers.Integral) or n_dofs < 1:
            raise ValueError(f"n_dofs must be a positive integer, got {n_dofs!r}")
        if isinstance(rate, bool) or not isinstance(rate, numbers.Real) or not RATE_MIN <= float(rate) <= RATE_MAX:
            raise ValueError(f"rate must be a number of Hz in [{RATE_MIN:g}, {RATE_MAX:g}], got {rate!r}")
        self.n = int(n_dofs)
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        self._use_numba = bool(use_numba and HAVE_NUMBA)
        self._buf = np.zeros((N_ROWS, self.n))
        self._buf[_LO] = -np.inf
        self._buf[_HI] = np.inf
        self._buf[_IALPHA] = 1.0
        self._cfg = np.zeros(_CFG_LEN)
        self._x = self._buf[_X]
        self._shape = (self.n,)
        self._set_groups(groups)
        self.order = 3
        self.limiter = "tanh"
        self.set_params(order=order, sigma=sigma, rho=rho, vel_limit=vel_limit, acc_limit=acc_limit,
                        jerk_limit=jerk_limit, limiter=limiter, bypass=bypass, pmin=pmin, pmax=pmax, beta=beta)
        self._x0: np.ndarray | None = None
        if x0 is not None:
            self._x0 = self._finite("x0", x0)
        self._one_pass = not self._grouped and self.n <= ONE_PASS_MAX_DOFS
        self._bind_step()
        self.reset()

    @classmethod
    def from_preset(cls, name: str, n_dofs: int, rate: float, order: int = 3, limiter: str = "tanh",
                    **overrides: Any) -> "MotionFilter":
        """A filter with one of the paper's presets W (or "regular"), A, B, C, D, E; overrides win."""
        p = preset(name)
        kw = dict(sigma=p.sigma, rho=p.rho, vel_limit=p.vel_limit, acc_limit=p.acc_limit,
                  jerk_limit=p.jerk_limit, bypass=p.bypass)
        kw.update(overrides)
        return cls(n_dofs, rate, order=order, limiter=limiter, **kw)

    # --- configuration ------------------------------------------------------------------------------
    def _finite(self, name: str, value: Any) -> np.ndarray:
        arr = _per_dof(name, value, self.n)
        _check(name, arr, np.isfinite(arr), "finite")
        return arr

    def _set_groups(self, groups: Sequence[Sequence[int]] | None) -> None:
        gid = np.arange(self.n, dtype=np.int64)
        member = np.zeros(self.n)
        seen: set[int] = set()
        next_id = self.n
        clean: list[list[int]] = []
        for g, members in enumerate(groups or []):
            try:
                idx = [int(i) for i in members]
            except (TypeError, ValueError):
                raise ValueError(f"groups[{g}] must be a list of DoF indices, got {members!r}") from None
            for i in idx:
                if not 0 <= i < self.n:
                    raise ValueError(f"groups[{g}] names DoF {i}, outside 0..{self.n - 1}")
                if i in seen:
                    raise ValueError(f"DoF {i} is in more than one group")
                seen.add(i)
            clean.append(idx)
            if len(idx) > 1:
                gid[idx] = next_id
                member[idx] = 1.0
                next_id += 1
        _, compact = np.unique(gid, return_inverse=True)  # group ids 0..G-1
        self._buf[_GID] = compact
        self._buf[_MEMBER] = member
        self._n_groups = int(compact.max()) + 1
        self._grouped = bool(member.any())
        self.groups = clean

    def set_params(self, *, order: int | None = None, sigma: Any = None, rho: Any = None, vel_limit: Any = None,
                   acc_limit: Any = None, jerk_limit: Any = None, limiter: str | None = None, bypass: Any = None,
                   pmin: Any = None, pmax: Any = None, beta: Any = None, clear_position_limits: bool = False) -> None:
        """Change parameters live, keeping the filter's state (no jump). Everything is validated
        before anything changes; None leaves a parameter as it is."""
        n = self.n
        prm = self._buf[_PARAMS].copy()  # staged: committed only if every check passes
        off = _KV

        def row(r: int) -> np.ndarray:
            return prm[r - off]

        if order is not None and (isinstance(order, bool) or order not in ORDERS):
            raise ValueError(f"order must be 1, 2 or 3, got {order!r}")
        if limiter is not None and limiter not in LIMITERS:
            raise ValueError(f"limiter must be 'tanh' or 'hard', got {limiter!r}")
        for name, value, r in (("vel_limit", vel_limit, _KV), ("acc_limit", acc_limit, _KA),
                               ("jerk_limit", jerk_limit, _KJ)):
            if value is not None:
                arr = _per_dof(name, value, n)
                _check(name, arr, np.isfinite(arr) & (arr > 0), "> 0 and finite")
                _check(name, arr, arr <= LIMIT_MAX, f"<= {LIMIT_MAX:g}")
                row(r)[:] = arr
        for name, value, r in (("sigma", sigma, _SIGMA), ("rho", rho, _RHO)):
            if value is not None:
                arr = _per_dof(name, value, n)
                _check(name, arr, np.isfinite(arr) & (arr >= 0) & (arr <= 1), "within [0, 1]")
                row(r)[:] = arr
        if beta is not None:
            arr = _per_dof("beta", beta, n)
            _check("beta", arr, np.isfinite(arr) & (arr >= 1), ">= 1")
            row(_BETA)[:] = arr
        if bypass is not None:
            row(_BYPASS)[:] = _per_dof("bypass", np.asarray(bypass, dtype=bool).astype(float), n)
        if clear_position_limits:
            row(_HASPOS)[:] = 0.0
            row(_LO)[:] = -np.inf
            row(_HI)[:] = np.inf
        if (pmin is None) != (pmax is None):
            raise ValueError("pmin and pmax must be given together")
        if pmin is not None:
            lo = _per_dof("pmin", pmin, n)
            hi = _per_dof("pmax", pmax, n)
            _check("pmin", lo, ~np.isnan(lo) & (lo != np.inf), "a number below +inf")
            _check("pmax", hi, ~np.isnan(hi) & (hi != -np.inf), "a number above -inf")
            _check("pmin", lo, lo < hi, "below pmax")
            row(_LO)[:], row(_HI)[:] = lo, hi
        # derived rows (the kernels never recompute them)
        for k_row, inv_row in ((_KV, _IHV), (_KA, _IHA), (_KJ, _IHJ)):
            row(inv_row)[:] = 1.0 / (0.5 * row(k_row))
        row(_EXPO)[:] = 1.0 - row(_SIGMA)
        row(_IOMR)[:] = 1.0 / (1.0 - np.minimum(row(_RHO), RHO_MAX))
        row(_TWOB)[:] = 2.0 * row(_BETA)
        row(_HMIX)[:] = 1.0 - row(_BYPASS)
        lo, hi = row(_LO), row(_HI)
        finite = np.isfinite(lo) & np.isfinite(hi)
        row(_HASPOS)[:] = finite
        with np.errstate(over="ignore", invalid="ignore"):
            span = hi - lo
            alpha = np.where(np.isfinite(span), span / 2.0, hi / 2.0 - lo / 2.0)  # no overflow near ±1e308
            center = lo + alpha
        row(_IALPHA)[:] = np.where(finite & (alpha > 0), 1.0 / np.where(alpha > 0, alpha, 1.0), 1.0)
        row(_CENTER)[:] = np.where(finite, center, 0.0)
        if self._grouped:
            self._check_groups(prm, off)
        self._buf[_PARAMS] = prm
        if order is not None:
            self.order = int(order)
        if limiter is not None:
            self.limiter = limiter
        self._hard = self.limiter == "hard"
        self._cfg[:] = (self.dt, self.order, float(self._hard), self._n_groups, float(self._grouped),
                        float(self._buf[_HASPOS].any()), float(np.all(self._buf[_BYPASS] != 0.0)), self.rate)

    def _check_groups(self, prm: np.ndarray, off: int) -> None:
        for members in self.groups:
            if len(members) < 2:
                continue
            for r, name in ((_KV, "vel_limit"), (_KA, "acc_limit"), (_KJ, "jerk_limit"), (_SIGMA, "sigma"),
                            (_RHO, "rho"), (_BYPASS, "bypass")):
                vals = prm[r - off, members]
                if not np.all(vals == vals[0]):
                    raise ValueError(f"{name} must be equal within a coupled group (DoFs {members})")

    # --- state ----------------------------------------------------------------------------------------
    def reset(self, x0: Any = None) -> None:
        """Back to rest: x = x0 (or each DoF's first set-point to come), velocity = acceleration = 0."""
        if x0 is not None:
            self._x0 = self._finite("x0", x0)
        self._buf[_STATE] = 0.0
        if self._x0 is not None:
            self._buf[_X] = self._x0
            self._buf[_SP] = self._x0
            self._buf[_INIT] = 1.0

    def set_state(self, position: Any, velocity: Any = None, acceleration: Any = None) -> None:
        """Set the filter's state (e.g. to the robot's measured pose) without a jump in the output.
        DoFs without a set-point yet hold `position`."""
        pos = self._finite("position", position)
        vel = np.zeros(self.n) if velocity is None else self._finite("velocity", velocity)
        acc = np.zeros(self.n) if acceleration is None else self._finite("acceleration", acceleration)
        b = self._buf
        b[_X] = pos
        b[_SP] = np.where(b[_INIT] != 0, b[_SP], pos)
        b[_INIT] = 1.0
        b[_VEL] = vel
        b[_ACC] = acc
        b[_JERK] = 0.0

    @property
    def position(self) -> np.ndarray:
        """Position after the latest step (n,), in the DoF's unit."""
        return self._buf[_X].copy()

    @property
    def velocity(self) -> np.ndarray:
        """Velocity after the latest step (n,): vel', exactly the finite difference of positions
        (0 after a position clip)."""
        return self._buf[_VEL].copy()

    @property
    def acceleration(self) -> np.ndarray:
        """Acceleration (n,): acc' for order 3; (vel' - vel)/dt for orders 1 and 2 (0 after a clip)."""
        return self._buf[_ACC].copy()

    @property
    def jerk(self) -> np.ndarray:
        """Jerk (n,): the finite difference of the reported acceleration, (acc' - acc)/dt, every order."""
        return self._buf[_JERK].copy()

    @property
    def setpoint(self) -> np.ndarray:
        """The latest set-point held per DoF (0 before the first one, unless x0 was given)."""
        return self._buf[_SP].copy()

    def params(self) -> dict[str, np.ndarray]:
        """Current per-DoF parameters (copies)."""
        b = self._buf
        return {"vel_limit": b[_KV].copy(), "acc_limit": b[_KA].copy(), "jerk_limit": b[_KJ].copy(),
                "sigma": b[_SIGMA].copy(), "rho": b[_RHO].copy(), "beta": b[_BETA].copy(),
                "bypass": b[_BYPASS] != 0, "pmin": b[_LO].copy(), "pmax": b[_HI].copy()}

    # --- stepping -------------------------------------------------------------------------------------
    def step(self, setpoints: Any) -> np.ndarray:
        """One output sample. `setpoints` (n,): new set-points, NaN for "no new set-point" (hold).

        Returns the new positions (n,) as a view of the internal state: copy it to keep it past the
        next step. Replaced per instance by `_bind_step` with a version that skips the conversion for
        a C-contiguous float64 array of shape (n,).
        """
        return self._step(setpoints)

    def _bind_step(self) -> None:
        buf, cfg, x, shape, n = self._buf, self._cfg, self._x, self._shape, self.n
        if self._use_numba:
            global _ENTRY_POINTS
            if _ENTRY_POINTS is None:
                _ENTRY_POINTS = _entry_points()
            kernel = _ENTRY_POINTS[1] if self._one_pass else _ENTRY_POINTS[0]
        else:
            kernel = _reference_step
        f64 = np.dtype(np.float64)
        ndarray = np.ndarray

        def fast(sp: Any) -> np.ndarray:
            # The common case costs two attribute checks and the compiled call.
            if type(sp) is ndarray and sp.dtype is f64 and sp.shape == shape and sp.flags.c_contiguous:
                kernel(sp, buf, cfg)
                return x
            try:
                arr = np.ascontiguousarray(sp, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"setpoints must be numbers (NaN = hold), got {sp!r}") from None
            if arr.ndim == 0:
                arr = np.full(n, float(arr))
            if arr.shape != shape:
                raise ValueError(f"setpoints must have shape ({n},), got {arr.shape}")
            if np.isinf(arr).any():
                raise ValueError(f"setpoint of DoF {int(np.flatnonzero(np.isinf(arr))[0])} is infinite")
            kernel(arr, buf, cfg)
            return x

        self._step = fast
        self.step = fast  # type: ignore[method-assign]  # instance attribute: skips the method lookup

    def run(self, setpoint_matrix: Any) -> FilterResult:
        """Filter a whole trajectory (T, n) of set-points (NaN = hold) from the current state.

        Exactly the same arithmetic as calling `step` T times (the state advances too); one compiled
        loop over time.
        """
        sps = np.ascontiguousarray(setpoint_matrix, dtype=float)
        if sps.ndim == 1 and self.n == 1:
            sps = sps[:, None]
        if sps.ndim != 2 or sps.shape[1] != self.n:
            raise ValueError(f"setpoint_matrix must have shape (T, {self.n}), got {sps.shape}")
        if np.isinf(sps).any():
            k, i = np.argwhere(np.isinf(sps))[0]
            raise ValueError(f"setpoint_matrix[{k}, {i}] (DoF {i}) is infinite")
        out = np.empty((4, sps.shape[0], self.n))
        if self._use_numba:
            _run_compiled(sps, self._buf, self._cfg, self._one_pass, out)
        else:
            for k in range(sps.shape[0]):
                _reference_step(sps[k], self._buf, self._cfg)
                out[:, k] = self._buf[_X:_JERK + 1]
        return FilterResult(out[0], out[1], out[2], out[3])


def filter_trajectory(setpoints: np.ndarray, rate: float, **kw: Any) -> FilterResult:
    """Convenience: filter a (T,) or (T, n) set-point trajectory with a fresh filter (`preset=` optional)."""
    sps = np.asarray(setpoints, dtype=float)
    one = sps.ndim == 1
    sps2 = sps[:, None] if one else sps
    name = kw.pop("preset", None)
    f = (MotionFilter.from_preset(name, sps2.shape[1], rate, **kw) if name
         else MotionFilter(sps2.shape[1], rate, **kw))
    res = f.run(sps2)
    if one:
        return FilterResult(res.position[:, 0], res.velocity[:, 0], res.acceleration[:, 0], res.jerk[:, 0])
    return res
