"""NMF parameters: accepted ranges, the layout of the filter's buffer, the paper's presets, and the
validation of per-DoF parameters into the buffer's parameter rows (with the rows derived from them).

Every parameter is a scalar or a per-DoF array. `stage_params` checks everything before anything
changes, so a rejected `set_params` leaves the filter as it was.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

RHO_MAX = 0.999  # the spec clamps rho to at most 0.999 (H divides by 1 - rho)
H_BASE_MAX = 1e12  # (|v|/(1-rho)) is capped here before the power: tanh(1e12**e - pi) has saturated
V_CLAMP = 1e290  # |induced velocity| cap: keeps (v/dt)/dt finite; every limiter saturated long before
LIMIT_MAX = 1e100  # largest accepted V, A, J (keeps reported derivatives finite at any accepted rate)
RATE_MIN, RATE_MAX = 1e-3, 1e6  # accepted output rates (Hz)
ONE_PASS_MAX_DOFS = 4  # the one-pass kernel wins only for a few DoFs (measured)
ORDERS = (1, 2, 3)
LIMITERS = ("tanh", "hard")

# Rows of the buffer: state, then parameters (some derived once in set_params), then scratch.
(
    _X,
    _VEL,
    _ACC,
    _JERK,
    _SP,
    _INIT,
    _KV,
    _KA,
    _KJ,
    _SIGMA,
    _RHO,
    _BETA,
    _BYPASS,
    _IHV,
    _IHA,
    _IHJ,
    _EXPO,
    _IOMR,
    _HASPOS,
    _LO,
    _HI,
    _CENTER,
    _IALPHA,
    _TWOB,
    _MEMBER,
    _GID,
    _HMIX,
    _WV,
    _WU,
    _WT,
    _WN,
    _WG1,
    _WG2,
) = range(33)
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
        return {
            "name": self.name,
            "meaning": self.meaning,
            "sigma": self.sigma,
            "rho": self.rho,
            "vel_limit": self.vel_limit,
            "acc_limit": self.acc_limit,
            "jerk_limit": self.jerk_limit,
            "bypass": self.bypass,
        }


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
# Validation of per-DoF values
# ------------------------------------------------------------------------------------------------


def per_dof(name: str, value: Any, n: int) -> np.ndarray:
    """`value` as one float per DoF (a scalar is repeated); ValueError naming `name` otherwise."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or one number per DoF, got {value!r}") from None
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have one value per DoF ({n}), got shape {arr.shape}")
    return arr.astype(float, copy=True)


def check(name: str, arr: np.ndarray, ok: np.ndarray, rule: str) -> None:
    """ValueError naming the first DoF where `ok` is False."""
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name} of DoF {i} must be {rule}, got {float(arr[i])!r}")


def finite(name: str, value: Any, n: int) -> np.ndarray:
    """`per_dof`, every value finite."""
    arr = per_dof(name, value, n)
    check(name, arr, np.isfinite(arr), "finite")
    return arr


@dataclass(frozen=True)
class Groups:
    """Coupled groups of DoFs (limited together by vector norm), as the kernels read them."""

    members: list[list[int]]  # as given (a one-DoF group is allowed and changes nothing)
    gid: np.ndarray  # compact group id per DoF, 0..count-1 (an uncoupled DoF is its own group)
    member: np.ndarray  # 1.0 for a DoF in a group of two or more, else 0.0
    count: int

    @property
    def coupled(self) -> bool:
        return bool(self.member.any())


def parse_groups(groups: Sequence[Sequence[int]] | None, n: int) -> Groups:
    """Check `groups` (lists of DoF indices, each DoF in one group at most) for `n` DoFs."""
    gid = np.arange(n, dtype=np.int64)
    member = np.zeros(n)
    seen: set[int] = set()
    next_id = n
    clean: list[list[int]] = []
    for g, members in enumerate(groups or []):
        try:
            idx = [int(i) for i in members]
        except (TypeError, ValueError):
            raise ValueError(f"groups[{g}] must be a list of DoF indices, got {members!r}") from None
        for i in idx:
            if not 0 <= i < n:
                raise ValueError(f"groups[{g}] names DoF {i}, outside 0..{n - 1}")
            if i in seen:
                raise ValueError(f"DoF {i} is in more than one group")
            seen.add(i)
        clean.append(idx)
        if len(idx) > 1:
            gid[idx] = next_id
            member[idx] = 1.0
            next_id += 1
    _, compact = np.unique(gid, return_inverse=True)  # group ids 0..G-1
    return Groups(clean, compact.astype(float), member, int(compact.max()) + 1)


# ------------------------------------------------------------------------------------------------
# Staging parameters: validated values into a copy of the parameter rows, derived rows recomputed
# ------------------------------------------------------------------------------------------------


def stage_params(
    rows: np.ndarray,
    groups: Groups,
    *,
    order: int | None = None,
    limiter: str | None = None,
    vel_limit: Any = None,
    acc_limit: Any = None,
    jerk_limit: Any = None,
    sigma: Any = None,
    rho: Any = None,
    beta: Any = None,
    bypass: Any = None,
    pmin: Any = None,
    pmax: Any = None,
    clear_position_limits: bool = False,
) -> np.ndarray:
    """A copy of the parameter rows `rows` (the buffer's `_PARAMS` slice) with the given parameters set
    (None leaves one as it is) and the derived rows recomputed. Raises ValueError naming the first bad
    value; `rows` never changes."""
    if order is not None and (isinstance(order, bool) or order not in ORDERS):
        raise ValueError(f"order must be 1, 2 or 3, got {order!r}")
    if limiter is not None and limiter not in LIMITERS:
        raise ValueError(f"limiter must be 'tanh' or 'hard', got {limiter!r}")
    prm = rows.copy()
    n = prm.shape[1]
    _set_limits(prm, n, vel_limit, acc_limit, jerk_limit)
    _set_character(prm, n, sigma, rho, beta, bypass)
    _set_position_limits(prm, n, pmin, pmax, clear_position_limits)
    _derive(prm)
    if groups.coupled:
        _check_groups(prm, groups)
    return prm


def _row(prm: np.ndarray, r: int) -> np.ndarray:
    """Row `r` of the buffer within the staged parameter rows."""
    return prm[r - _KV]


def _set_limits(prm: np.ndarray, n: int, vel_limit: Any, acc_limit: Any, jerk_limit: Any) -> None:
    for name, value, r in (
        ("vel_limit", vel_limit, _KV),
        ("acc_limit", acc_limit, _KA),
        ("jerk_limit", jerk_limit, _KJ),
    ):
        if value is not None:
            arr = per_dof(name, value, n)
            check(name, arr, np.isfinite(arr) & (arr > 0), "> 0 and finite")
            check(name, arr, arr <= LIMIT_MAX, f"<= {LIMIT_MAX:g}")
            _row(prm, r)[:] = arr


def _set_character(prm: np.ndarray, n: int, sigma: Any, rho: Any, beta: Any, bypass: Any) -> None:
    for name, value, r in (("sigma", sigma, _SIGMA), ("rho", rho, _RHO)):
        if value is not None:
            arr = per_dof(name, value, n)
            check(name, arr, np.isfinite(arr) & (arr >= 0) & (arr <= 1), "within [0, 1]")
            _row(prm, r)[:] = arr
    if beta is not None:
        arr = per_dof("beta", beta, n)
        check("beta", arr, np.isfinite(arr) & (arr >= 1), ">= 1")
        _row(prm, _BETA)[:] = arr
    if bypass is not None:
        _row(prm, _BYPASS)[:] = per_dof("bypass", np.asarray(bypass, dtype=bool).astype(float), n)


def _set_position_limits(prm: np.ndarray, n: int, pmin: Any, pmax: Any, clear: bool) -> None:
    if clear:
        _row(prm, _HASPOS)[:] = 0.0
        _row(prm, _LO)[:] = -np.inf
        _row(prm, _HI)[:] = np.inf
    if (pmin is None) != (pmax is None):
        raise ValueError("pmin and pmax must be given together")
    if pmin is not None:
        lo = per_dof("pmin", pmin, n)
        hi = per_dof("pmax", pmax, n)
        check("pmin", lo, ~np.isnan(lo) & (lo != np.inf), "a number below +inf")
        check("pmax", hi, ~np.isnan(hi) & (hi != -np.inf), "a number above -inf")
        check("pmin", lo, lo < hi, "below pmax")
        _row(prm, _LO)[:], _row(prm, _HI)[:] = lo, hi


def _derive(prm: np.ndarray) -> None:
    """The derived rows (the kernels never recompute them)."""
    for k_row, inv_row in ((_KV, _IHV), (_KA, _IHA), (_KJ, _IHJ)):
        _row(prm, inv_row)[:] = 1.0 / (0.5 * _row(prm, k_row))
    _row(prm, _EXPO)[:] = 1.0 - _row(prm, _SIGMA)
    _row(prm, _IOMR)[:] = 1.0 / (1.0 - np.minimum(_row(prm, _RHO), RHO_MAX))
    _row(prm, _TWOB)[:] = 2.0 * _row(prm, _BETA)
    _row(prm, _HMIX)[:] = 1.0 - _row(prm, _BYPASS)
    lo, hi = _row(prm, _LO), _row(prm, _HI)
    finite_both = np.isfinite(lo) & np.isfinite(hi)
    _row(prm, _HASPOS)[:] = finite_both
    with np.errstate(over="ignore", invalid="ignore"):
        span = hi - lo
        alpha = np.where(np.isfinite(span), span / 2.0, hi / 2.0 - lo / 2.0)  # no overflow near ±1e308
        center = lo + alpha
    _row(prm, _IALPHA)[:] = np.where(finite_both & (alpha > 0), 1.0 / np.where(alpha > 0, alpha, 1.0), 1.0)
    _row(prm, _CENTER)[:] = np.where(finite_both, center, 0.0)


def _check_groups(prm: np.ndarray, groups: Groups) -> None:
    for members in groups.members:
        if len(members) < 2:
            continue
        for r, name in (
            (_KV, "vel_limit"),
            (_KA, "acc_limit"),
            (_KJ, "jerk_limit"),
            (_SIGMA, "sigma"),
            (_RHO, "rho"),
            (_BYPASS, "bypass"),
        ):
            vals = _row(prm, r)[members]
            if not np.all(vals == vals[0]):
                raise ValueError(f"{name} must be equal within a coupled group (DoFs {members})")
