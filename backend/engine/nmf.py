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

Every parameter is a scalar or a per-DoF array, so one filter serves a whole robot. The hot path is a
numba-compiled kernel over structure-of-arrays state (a pure-numpy reference implementation gives
the same numbers and is the fallback when numba is unavailable).

Known limits of the spec's guarantees (found by property testing; the filter is left exactly as
specified): the spec bounds the *output's* finite differences (|v| <= V/2, |a| <= A, |j| <= J with
tanh). The limiters compress their arguments and that compression is not charged to the next
derivative's budget, so in rare reversals the jerk of the output exceeds J slightly. Measured over
4000 random cases each (V 0.5-200, A = 2-20 V, J = 10-200 A): worst jerk/J 0.66 at 30 Hz, 0.72 at
60 Hz, 0.88 at 100 Hz, 0.95 at 200 Hz, 1.05 at 500 Hz; hypothesis found 1.009 at 200 Hz and 1.023
at 500 Hz (a one-sample set-point impulse followed by a reversal). The velocity and acceleration
bounds held in every case (acceleration/A <= 0.8). tests/test_nmf_properties.py checks up to 200 Hz.

Units: positions in the DoF's unit (rad, m), velocity limit V per s, acceleration A per s², jerk J
per s³; `rate` in Hz (samples per second).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

try:  # numba is a hard dependency in pyproject; the fallback keeps the filter usable without it
    from numba import njit

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False

RHO_MAX = 0.999
ONE_PASS_MAX_DOFS = 4  # the one-pass kernel wins only for a few DoFs (measured)
ORDERS = (1, 2, 3)
LIMITERS = ("tanh", "hard")

# Rows of the packed parameter matrix (P, n): one row per per-DoF parameter.
_V, _A, _J, _SIGMA, _RHO, _PMIN, _PMAX, _BETA, _BYPASS, _HASPOS = range(10)
N_PARAMS = 10
# Rows of the packed state matrix (S, n).
_X, _VEL, _ACC, _JERK, _SP, _INIT = range(6)
N_STATE = 6


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
    key = str(name).strip().upper()
    key = _PRESET_ALIASES.get(key, key)
    if key not in PRESETS:
        raise ValueError(f"unknown preset '{name}' (one of {', '.join(PRESETS)} or 'regular')")
    return PRESETS[key]


# ------------------------------------------------------------------------------------------------
# Building blocks (numpy, exact formulas of the spec; used by the reference step and the figures)
# ------------------------------------------------------------------------------------------------


def lam(u: np.ndarray | float, k: np.ndarray | float, hard: bool = False) -> np.ndarray:
    """The limiter: `k/2 tanh(u/(k/2))` (never reaches k/2) or, hard, `clip(u, -k, k)`."""
    u = np.asarray(u, dtype=float)
    if hard:
        return np.clip(u, -k, k)
    h = np.asarray(k, dtype=float) / 2.0
    return h * np.tanh(u / h)


def omega(v: np.ndarray | float, x: np.ndarray | float, pmin: float, pmax: float, beta: float) -> np.ndarray:
    """Position saturation Ω: the induced velocity fades to 0 when moving toward a position limit."""
    v = np.asarray(v, dtype=float)
    x = np.asarray(x, dtype=float)
    alpha = (pmax - pmin) / 2.0
    center = pmin + alpha
    r = np.minimum(np.abs((x - center) / alpha), 1.0)
    toward = ((x > center) & (v > 0)) | ((x < center) & (v < 0))
    return np.where(toward, v * (1.0 - r ** (2.0 * beta)), v)


def h_gain(speed: np.ndarray | float, sigma: np.ndarray | float, rho: np.ndarray | float) -> np.ndarray:
    """H's gain g(|v|) so that H(v) = v g(|v|): `(tanh((|v|/(1-rho))^(1-sigma) - pi) + 1) / 2`.

    Finite for every sigma, rho in [0, 1] and finite |v| (0^0 = 1 at sigma = 1; rho clamped to 0.999).
    """
    speed = np.abs(np.asarray(speed, dtype=float))
    rho = np.minimum(np.asarray(rho, dtype=float), RHO_MAX)
    base = speed / (1.0 - rho)
    # tanh saturates long before the power overflows: cap the argument to keep it finite.
    powered = np.power(np.minimum(base, 1e12), 1.0 - np.asarray(sigma, dtype=float))
    return 0.5 * (np.tanh(powered - math.pi) + 1.0)


def stabilise(v: np.ndarray | float, sigma: float, rho: float) -> np.ndarray:
    """The stabilisation (transfer) function H(v) = v/2 (tanh((|v|/(1-rho))^(1-sigma) - pi) + 1)."""
    v = np.asarray(v, dtype=float)
    return v * h_gain(np.abs(v), sigma, rho)


# ------------------------------------------------------------------------------------------------
# The step kernel. One source, two back ends: compiled with numba, or run by the Python interpreter
# on numpy scalars for the reference. Loops are over DoFs *inside compiled code*.
# ------------------------------------------------------------------------------------------------


def _group_norms(vec, gid, n_groups, grouped, out, acc):
    """|vec| per DoF, or the Euclidean norm of the DoF's group when DoFs are coupled."""
    n = vec.shape[0]
    if not grouped:
        for i in range(n):
            out[i] = abs(vec[i])
        return
    for g in range(n_groups):
        acc[g] = 0.0
    for i in range(n):
        acc[gid[i]] += vec[i] * vec[i]
    for i in range(n):
        out[i] = math.sqrt(acc[gid[i]])


def _limit_vec(vec, k, hard, gid, n_groups, grouped, norms, acc):
    """lam applied per DoF, or to each group's norm with the vector scaled proportionally (in place)."""
    _group_norms(vec, gid, n_groups, grouped, norms, acc)
    n = vec.shape[0]
    for i in range(n):
        m = norms[i]
        if m == 0.0:
            continue
        if hard:
            lim = m if m <= k[i] else k[i]
        else:
            half = 0.5 * k[i]
            lim = half * math.tanh(m / half)
        vec[i] = vec[i] * (lim / m)


def _step_kernel(sp_in, buf, cfg, gid):
    """Advance the filter by one sample (state updated in place).

    sp_in (n,) set-points (NaN = hold); buf (S + P + 6, n) = state rows, parameter rows, scratch rows;
    cfg = [dt, order, hard, n_groups, grouped]; gid (n,) group index of each DoF. Few arguments on
    purpose: each one costs the compiled call's dispatcher time, which dominates at 1 DoF.
    """
    st = buf[:N_STATE]
    prm = buf[N_STATE:N_STATE + N_PARAMS]
    work = buf[N_STATE + N_PARAMS:]
    dt = cfg[0]
    order = int(cfg[1])
    hard = cfg[2] != 0.0
    n_groups = int(cfg[3])
    grouped = cfg[4] != 0.0
    n = sp_in.shape[0]
    v = work[0]
    tmp = work[1]
    norms = work[2]
    acc_g = work[3]
    vel_new = work[4]
    acc_new = work[5]
    for i in range(n):
        s = sp_in[i]
        if s == s:  # not NaN
            st[_SP, i] = s
            if st[_INIT, i] == 0.0:
                st[_X, i] = s
                st[_INIT, i] = 1.0
    # induced velocity with position saturation
    for i in range(n):
        x = st[_X, i]
        vi = (st[_SP, i] - x) / dt if st[_INIT, i] != 0.0 else 0.0
        if prm[_HASPOS, i] != 0.0:
            alpha = 0.5 * (prm[_PMAX, i] - prm[_PMIN, i])
            center = prm[_PMIN, i] + alpha
            if (x > center and vi > 0.0) or (x < center and vi < 0.0):
                r = abs((x - center) / alpha)
                if r > 1.0:
                    r = 1.0
                vi = vi * (1.0 - r ** (2.0 * prm[_BETA, i]))
        v[i] = vi
    # H: gain from |v| (the group's norm for coupled DoFs)
    _group_norms(v, gid, n_groups, grouped, norms, acc_g)
    for i in range(n):
        if prm[_BYPASS, i] == 0.0:
            rho = prm[_RHO, i]
            if rho > RHO_MAX:
                rho = RHO_MAX
            base = norms[i] / (1.0 - rho)
            if base > 1e12:
                base = 1e12
            g = 0.5 * (math.tanh(base ** (1.0 - prm[_SIGMA, i]) - math.pi) + 1.0)
            v[i] = v[i] * g  # v now holds u = H(v)
    if order == 1:
        for i in range(n):
            vel_new[i] = v[i]
        _limit_vec(vel_new, prm[_V], hard, gid, n_groups, grouped, norms, acc_g)
        for i in range(n):
            acc_new[i] = (vel_new[i] - st[_VEL, i]) / dt
    elif order == 2:
        for i in range(n):
            acc_new[i] = (v[i] - st[_VEL, i]) / dt
        _limit_vec(acc_new, prm[_A], hard, gid, n_groups, grouped, norms, acc_g)
        for i in range(n):
            vel_new[i] = st[_VEL, i] + acc_new[i] * dt
        _limit_vec(vel_new, prm[_V], hard, gid, n_groups, grouped, norms, acc_g)
        for i in range(n):
            acc_new[i] = (vel_new[i] - st[_VEL, i]) / dt
    else:
        for i in range(n):
            tmp[i] = ((v[i] - st[_VEL, i]) / dt - st[_ACC, i]) / dt
        _limit_vec(tmp, prm[_J], hard, gid, n_groups, grouped, norms, acc_g)
        for i in range(n):
            acc_new[i] = st[_ACC, i] + tmp[i] * dt
        _limit_vec(acc_new, prm[_A], hard, gid, n_groups, grouped, norms, acc_g)
        for i in range(n):
            vel_new[i] = st[_VEL, i] + acc_new[i] * dt
        _limit_vec(vel_new, prm[_V], hard, gid, n_groups, grouped, norms, acc_g)
    for i in range(n):
        x_new = st[_X, i] + vel_new[i] * dt
        a = acc_new[i]
        vn = vel_new[i]
        if prm[_HASPOS, i] != 0.0 and (x_new < prm[_PMIN, i] or x_new > prm[_PMAX, i]):
            x_new = min(max(x_new, prm[_PMIN, i]), prm[_PMAX, i])
            vn = 0.0
            a = 0.0
        st[_JERK, i] = (a - st[_ACC, i]) / dt
        st[_X, i] = x_new
        st[_VEL, i] = vn
        st[_ACC, i] = a


def _tanh_limit(u, k, hard):
    """lam for one uncoupled value, with the same operation order as `_limit_vec` (bit-identical)."""
    m = abs(u)
    if m == 0.0:
        return u
    if hard:
        lim = m if m <= k else k
    else:
        half = 0.5 * k
        lim = half * math.tanh(m / half)
    return u * (lim / m)


def _step_fused(sp_in, buf, cfg, gid):
    """The step for a few uncoupled DoFs in one pass (same arithmetic as `_step_kernel`).

    Measured: faster than the multi-pass kernel up to ~4 DoFs (0.6 vs 0.8 µs at 1 DoF), slower
    beyond (the multi-pass loops pipeline better), so it serves small filters only.
    """
    dt = cfg[0]
    order = int(cfg[1])
    hard = cfg[2] != 0.0
    n = sp_in.shape[0]
    for i in range(n):
        s = sp_in[i]
        if s == s:
            buf[_SP, i] = s
            if buf[_INIT, i] == 0.0:
                buf[_X, i] = s
                buf[_INIT, i] = 1.0
        x = buf[_X, i]
        vel = buf[_VEL, i]
        acc = buf[_ACC, i]
        p0 = N_STATE
        vi = (buf[_SP, i] - x) / dt if buf[_INIT, i] != 0.0 else 0.0
        if buf[p0 + _HASPOS, i] != 0.0:
            alpha = 0.5 * (buf[p0 + _PMAX, i] - buf[p0 + _PMIN, i])
            center = buf[p0 + _PMIN, i] + alpha
            if (x > center and vi > 0.0) or (x < center and vi < 0.0):
                r = abs((x - center) / alpha)
                if r > 1.0:
                    r = 1.0
                vi = vi * (1.0 - r ** (2.0 * buf[p0 + _BETA, i]))
        if buf[p0 + _BYPASS, i] == 0.0:
            rho = buf[p0 + _RHO, i]
            if rho > RHO_MAX:
                rho = RHO_MAX
            base = abs(vi) / (1.0 - rho)
            if base > 1e12:
                base = 1e12
            g = 0.5 * (math.tanh(base ** (1.0 - buf[p0 + _SIGMA, i]) - math.pi) + 1.0)
            vi = vi * g
        if order == 1:
            vel_new = _tanh_limit(vi, buf[p0 + _V, i], hard)
            acc_new = (vel_new - vel) / dt
        elif order == 2:
            acc_new = _tanh_limit((vi - vel) / dt, buf[p0 + _A, i], hard)
            vel_new = _tanh_limit(vel + acc_new * dt, buf[p0 + _V, i], hard)
            acc_new = (vel_new - vel) / dt
        else:
            jerk = _tanh_limit(((vi - vel) / dt - acc) / dt, buf[p0 + _J, i], hard)
            acc_new = _tanh_limit(acc + jerk * dt, buf[p0 + _A, i], hard)
            vel_new = _tanh_limit(vel + acc_new * dt, buf[p0 + _V, i], hard)
        x_new = x + vel_new * dt
        if buf[p0 + _HASPOS, i] != 0.0 and (x_new < buf[p0 + _PMIN, i] or x_new > buf[p0 + _PMAX, i]):
            x_new = min(max(x_new, buf[p0 + _PMIN, i]), buf[p0 + _PMAX, i])
            vel_new = 0.0
            acc_new = 0.0
        buf[_JERK, i] = (acc_new - acc) / dt
        buf[_X, i] = x_new
        buf[_VEL, i] = vel_new
        buf[_ACC, i] = acc_new


def _run_kernel(sps, buf, cfg, gid, out):
    """Filter a whole trajectory: sps (T, n); out (4, T, n) position, velocity, acceleration, jerk."""
    for t in range(sps.shape[0]):
        _step_kernel(sps[t], buf, cfg, gid)
        for i in range(sps.shape[1]):
            out[0, t, i] = buf[_X, i]
            out[1, t, i] = buf[_VEL, i]
            out[2, t, i] = buf[_ACC, i]
            out[3, t, i] = buf[_JERK, i]


if HAVE_NUMBA:

    def _compile():
        """Compile the kernels with their helpers bound to compiled versions (numba needs jitted callees)."""
        import types

        g = dict(globals())
        for name in ("_group_norms", "_limit_vec", "_tanh_limit", "_step_kernel", "_run_kernel"):
            fn = globals()[name]
            g[name] = njit(cache=False)(types.FunctionType(fn.__code__, g, name))
        fused = njit(cache=False)(types.FunctionType(_step_fused.__code__, g, "_step_fused"))
        return g["_step_kernel"], g["_run_kernel"], fused

    _step_compiled, _run_compiled, _fused_compiled = _compile()

    def _direct_step():
        """The compiled step for C-contiguous float64/int64 arrays, called without the dispatcher's
        type resolution (it is most of the cost at 1 DoF)."""
        from numba import types as nt

        f64_1d, f64_2d, i64_1d = nt.float64[::1], nt.float64[:, ::1], nt.int64[::1]
        sig = (f64_1d, f64_2d, f64_1d, i64_1d)
        out = []
        for disp in (_step_compiled, _fused_compiled):
            disp.compile(sig)
            out.append(disp.overloads[sig].entry_point)
        return tuple(out)
else:  # pragma: no cover
    _step_compiled = _run_compiled = None
    _direct_step = None


_DIRECT_STEP = None


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


def _per_dof(name: str, value: Any, n: int, *, allow_none: bool = False) -> np.ndarray | None:
    if value is None:
        if allow_none:
            return None
        raise ValueError(f"{name} is required")
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have one value per DoF ({n}), got shape {arr.shape}")
    return arr.astype(float, copy=True)


def _check(name: str, arr: np.ndarray, ok: np.ndarray, rule: str) -> None:
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name} of DoF {i} must be {rule}, got {arr[i]!r}")


class MotionFilter:
    """The NMF over `n_dofs` DoFs at `rate` Hz (see the module doc for the equations).

    Parameters (each a scalar or a per-DoF array):
      order 1|2|3; sigma, rho in [0, 1]; vel_limit, acc_limit, jerk_limit > 0 (per s, s², s³);
      limiter "tanh" | "hard"; bypass (H replaced by identity); pmin < pmax (optional, both or
      neither); beta >= 1; x0 (initial positions; default: each DoF's first set-point);
      groups: lists of DoF indices limited together by vector norm.
    """

    def __init__(self, n_dofs: int, rate: float, order: int = 3, sigma: Any = 0.5, rho: Any = 0.5,
                 vel_limit: Any = 20.0, acc_limit: Any = 100.0, jerk_limit: Any = 10000.0,
                 limiter: str = "tanh", bypass: Any = False, pmin: Any = None, pmax: Any = None,
                 beta: Any = 5.0, x0: Any = None, groups: Sequence[Sequence[int]] | None = None,
                 use_numba: bool = True):
        if not isinstance(n_dofs, (int, np.integer)) or n_dofs < 1:
            raise ValueError(f"n_dofs must be a positive integer, got {n_dofs!r}")
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate must be a positive number of Hz, got {rate!r}")
        self.n = int(n_dofs)
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        self._use_numba = bool(use_numba and HAVE_NUMBA)
        self._buf = np.zeros((N_STATE + N_PARAMS + 6, self.n))  # state, parameters, scratch
        self._st = self._buf[:N_STATE]
        self._prm = self._buf[N_STATE:N_STATE + N_PARAMS]
        self._cfg = np.zeros(5)
        self._x = self._buf[_X]
        self._shape = (self.n,)
        self._kernel = _step_kernel
        if self._use_numba:
            global _DIRECT_STEP
            if _DIRECT_STEP is None:
                _DIRECT_STEP = _direct_step()
        self._set_groups(groups)
        if self._use_numba:
            multi_pass, one_pass = _DIRECT_STEP
            self._kernel = one_pass if (not self._grouped and self.n <= ONE_PASS_MAX_DOFS) else multi_pass
        self._bind_step()
        self.order = 3
        self.limiter = "tanh"
        self.set_params(order=order, sigma=sigma, rho=rho, vel_limit=vel_limit, acc_limit=acc_limit,
                        jerk_limit=jerk_limit, limiter=limiter, bypass=bypass, pmin=pmin, pmax=pmax, beta=beta)
        self._x0 = _per_dof("x0", x0, self.n, allow_none=True)
        if self._x0 is not None:
            _check("x0", self._x0, np.isfinite(self._x0), "finite")
        self.reset()

    @classmethod
    def from_preset(cls, name: str, n_dofs: int, rate: float, order: int = 3, limiter: str = "tanh",
                    **overrides: Any) -> "MotionFilter":
        """A filter with one of the paper's presets W, A, B, C, D, E (overrides win)."""
        p = preset(name)
        kw = dict(sigma=p.sigma, rho=p.rho, vel_limit=p.vel_limit, acc_limit=p.acc_limit,
                  jerk_limit=p.jerk_limit, bypass=p.bypass)
        kw.update(overrides)
        return cls(n_dofs, rate, order=order, limiter=limiter, **kw)

    # --- configuration ------------------------------------------------------------------------------
    def _set_groups(self, groups: Sequence[Sequence[int]] | None) -> None:
        gid = np.arange(self.n, dtype=np.int64)
        seen: set[int] = set()
        next_id = self.n
        for g, members in enumerate(groups or []):
            idx = [int(i) for i in members]
            for i in idx:
                if not 0 <= i < self.n:
                    raise ValueError(f"groups[{g}] names DoF {i}, outside 0..{self.n - 1}")
                if i in seen:
                    raise ValueError(f"DoF {i} is in more than one group")
                seen.add(i)
            gid[idx] = next_id
            next_id += 1
        # Compact group ids to 0..G-1
        _, self._gid = np.unique(gid, return_inverse=True)
        self._gid = self._gid.astype(np.int64)
        self._n_groups = int(self._gid.max()) + 1
        self._grouped = self._n_groups < self.n
        self.groups = [list(map(int, m)) for m in (groups or [])]

    def set_params(self, *, order: int | None = None, sigma: Any = None, rho: Any = None, vel_limit: Any = None,
                   acc_limit: Any = None, jerk_limit: Any = None, limiter: str | None = None, bypass: Any = None,
                   pmin: Any = None, pmax: Any = None, beta: Any = None, clear_position_limits: bool = False) -> None:
        """Change parameters live, keeping the filter's state (no jump). Validates everything first."""
        prm = self._prm.copy()
        n = self.n
        if order is not None and order not in ORDERS:
            raise ValueError(f"order must be 1, 2 or 3, got {order!r}")
        if limiter is not None and limiter not in LIMITERS:
            raise ValueError(f"limiter must be 'tanh' or 'hard', got {limiter!r}")
        for name, value, row in (("vel_limit", vel_limit, _V), ("acc_limit", acc_limit, _A),
                                 ("jerk_limit", jerk_limit, _J)):
            if value is not None:
                arr = _per_dof(name, value, n)
                _check(name, arr, np.isfinite(arr) & (arr > 0), "> 0 and finite")
                prm[row] = arr
        for name, value, row in (("sigma", sigma, _SIGMA), ("rho", rho, _RHO)):
            if value is not None:
                arr = _per_dof(name, value, n)
                _check(name, arr, np.isfinite(arr) & (arr >= 0) & (arr <= 1), "within [0, 1]")
                prm[row] = arr
        if beta is not None:
            arr = _per_dof("beta", beta, n)
            _check("beta", arr, np.isfinite(arr) & (arr >= 1), ">= 1")
            prm[_BETA] = arr
        if bypass is not None:
            prm[_BYPASS] = _per_dof("bypass", np.asarray(bypass, dtype=bool).astype(float), n)
        if clear_position_limits:
            prm[_HASPOS] = 0.0
        if (pmin is None) != (pmax is None):
            raise ValueError("pmin and pmax must be given together")
        if pmin is not None:
            lo = _per_dof("pmin", pmin, n)
            hi = _per_dof("pmax", pmax, n)
            _check("pmin", lo, np.isfinite(lo), "finite")
            _check("pmax", hi, np.isfinite(hi), "finite")
            _check("pmin", lo, lo < hi, f"below pmax")
            prm[_PMIN], prm[_PMAX], prm[_HASPOS] = lo, hi, 1.0
        if self._grouped:
            for g in range(self._n_groups):
                members = np.flatnonzero(self._gid == g)
                if members.size > 1:
                    for row, name in ((_V, "vel_limit"), (_A, "acc_limit"), (_J, "jerk_limit")):
                        vals = prm[row, members]
                        if not np.all(vals == vals[0]):
                            raise ValueError(f"{name} must be equal within a coupled group (DoFs {members.tolist()})")
        self._prm[:] = prm
        if order is not None:
            self.order = int(order)
        if limiter is not None:
            self.limiter = limiter
        self._hard = self.limiter == "hard"
        self._cfg[:] = (self.dt, self.order, float(self._hard), self._n_groups, float(self._grouped))

    # --- state ----------------------------------------------------------------------------------------
    def reset(self, x0: Any = None) -> None:
        """Back to rest: x = x0 (or the first set-point to come), velocity = acceleration = 0."""
        if x0 is not None:
            self._x0 = _per_dof("x0", x0, self.n)
        self._st[:] = 0.0
        if self._x0 is not None:
            self._st[_X] = self._x0
            self._st[_SP] = self._x0
            self._st[_INIT] = 1.0

    def set_state(self, position: Any, velocity: Any = None, acceleration: Any = None) -> None:
        """Set the filter's state (e.g. to the robot's measured pose) without a jump in the output."""
        pos = _per_dof("position", position, self.n)
        _check("position", pos, np.isfinite(pos), "finite")
        self._st[_X] = pos
        self._st[_SP] = np.where(self._st[_INIT] != 0, self._st[_SP], pos)
        self._st[_INIT] = 1.0
        self._st[_VEL] = 0.0 if velocity is None else _per_dof("velocity", velocity, self.n)
        self._st[_ACC] = 0.0 if acceleration is None else _per_dof("acceleration", acceleration, self.n)
        self._st[_JERK] = 0.0

    @property
    def position(self) -> np.ndarray:
        return self._st[_X].copy()

    @property
    def velocity(self) -> np.ndarray:
        return self._st[_VEL].copy()

    @property
    def acceleration(self) -> np.ndarray:
        return self._st[_ACC].copy()

    @property
    def jerk(self) -> np.ndarray:
        return self._st[_JERK].copy()

    @property
    def setpoint(self) -> np.ndarray:
        return self._st[_SP].copy()

    def params(self) -> dict[str, np.ndarray]:
        return {"vel_limit": self._prm[_V].copy(), "acc_limit": self._prm[_A].copy(),
                "jerk_limit": self._prm[_J].copy(), "sigma": self._prm[_SIGMA].copy(),
                "rho": self._prm[_RHO].copy(), "beta": self._prm[_BETA].copy(),
                "bypass": self._prm[_BYPASS] != 0}

    # --- stepping -------------------------------------------------------------------------------------
    def step(self, setpoints: Any) -> np.ndarray:
        """One output sample. `setpoints` (n,): new set-points, NaN for "no new set-point" (hold).

        Returns the new positions (a view of internal state: copy it to keep it past the next step).
        The fast path (a C-contiguous float64 array of shape (n,)) is bound per instance in
        `_bind_step`, so a 1-DoF step costs about one compiled call.
        """
        return self._step(setpoints)

    def _bind_step(self) -> None:
        kernel, buf, cfg, gid, x, shape, n = self._kernel, self._buf, self._cfg, self._gid, self._x, self._shape, self.n
        f64 = np.dtype(np.float64)
        ndarray = np.ndarray

        def fast(sp: Any) -> np.ndarray:
            if type(sp) is ndarray and sp.dtype is f64 and sp.shape == shape and sp.flags.c_contiguous:
                kernel(sp, buf, cfg, gid)
                return x
            arr = np.ascontiguousarray(sp, dtype=float)
            if arr.ndim == 0:
                arr = np.full(n, float(arr))
            if arr.shape != shape:
                raise ValueError(f"setpoints must have shape ({n},), got {arr.shape}")
            kernel(arr, buf, cfg, gid)
            return x

        self._step = fast
        self.step = fast  # type: ignore[method-assign]  # instance attribute: skips the method lookup

    def run(self, setpoint_matrix: Any) -> FilterResult:
        """Filter a whole trajectory (T, n) of set-points (NaN = hold) from the current state.

        Exactly the same arithmetic as calling `step` T times (the state advances too).
        """
        sps = np.ascontiguousarray(setpoint_matrix, dtype=float)
        if sps.ndim == 1 and self.n == 1:
            sps = sps[:, None]
        if sps.ndim != 2 or sps.shape[1] != self.n:
            raise ValueError(f"setpoint_matrix must have shape (T, {self.n}), got {sps.shape}")
        if np.isinf(sps).any():
            raise ValueError("setpoint_matrix contains infinite values")
        out = np.empty((4, sps.shape[0], self.n))
        (_run_compiled if self._use_numba else _run_kernel)(sps, self._buf, self._cfg, self._gid, out)
        return FilterResult(out[0], out[1], out[2], out[3])


def filter_trajectory(setpoints: np.ndarray, rate: float, **kw: Any) -> FilterResult:
    """Convenience: filter a (T,) or (T, n) set-point trajectory with a fresh filter."""
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
