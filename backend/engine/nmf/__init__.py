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

Implementation (this package)
- `params`: accepted ranges, presets, and the validation of parameters. State and parameters are
  structure-of-arrays rows of one float64 buffer; divisions by constants are multiplications by their
  inverses computed once when parameters are set (1/dt = rate, 2/k, 1/(1-rho), 1/alpha): a rounding
  difference of at most an ulp from the printed formulas, for several times fewer divisions.
- `kernels`: the hot path, numba-compiled: a one-pass loop for a few DoFs, and for more DoFs simple
  passes over the DoFs that the compiler turns into SIMD code. `tanh` and H's power are our own
  branch-free implementations (`_tanh` within 4 ulp of libm's; `_pow` within 2e-13 relative; see
  tests) because libm's cannot be vectorised. Ω's power (only near position limits) stays libm's.
- `reference`: the spec's formulas in numpy (lam, omega, h_gain, stabilise), and `_reference_step`, a
  pure-numpy implementation of the kernels' arithmetic vectorised over DoFs. The tests check the
  compiled kernels against it (to 1e-11 relative: LLVM may fuse multiply-adds); it is the fallback when
  numba is missing.
- `filter`: the public `MotionFilter` and `filter_trajectory`.
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

from backend.engine.nmf.fast_math import HAVE_NUMBA
from backend.engine.nmf.filter import FilterResult, MotionFilter, filter_trajectory
from backend.engine.nmf.params import (
    H_BASE_MAX,
    LIMIT_MAX,
    LIMITERS,
    ONE_PASS_MAX_DOFS,
    ORDERS,
    PRESETS,
    RATE_MAX,
    RATE_MIN,
    RHO_MAX,
    V_CLAMP,
    Preset,
    preset,
)
from backend.engine.nmf.reference import h_gain, lam, omega, pow_np, stabilise, tanh_np

__all__ = [
    "HAVE_NUMBA",
    "H_BASE_MAX",
    "LIMITERS",
    "LIMIT_MAX",
    "ONE_PASS_MAX_DOFS",
    "ORDERS",
    "PRESETS",
    "RATE_MAX",
    "RATE_MIN",
    "RHO_MAX",
    "V_CLAMP",
    "FilterResult",
    "MotionFilter",
    "Preset",
    "filter_trajectory",
    "h_gain",
    "lam",
    "omega",
    "pow_np",
    "preset",
    "stabilise",
    "tanh_np",
]
