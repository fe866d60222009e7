"""The NMF's public API: `MotionFilter` (live, step by step or a whole trajectory at once) and
`filter_trajectory`."""

from __future__ import annotations

import functools
import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.engine.nmf.fast_math import HAVE_NUMBA
from backend.engine.nmf.kernels import _entry_points, _run_compiled
from backend.engine.nmf.params import (
    _ACC,
    _BETA,
    _BYPASS,
    _CFG_LEN,
    _GID,
    _HASPOS,
    _HI,
    _IALPHA,
    _INIT,
    _JERK,
    _KA,
    _KJ,
    _KV,
    _LO,
    _MEMBER,
    _PARAMS,
    _RHO,
    _SIGMA,
    _SP,
    _STATE,
    _VEL,
    _X,
    N_ROWS,
    ONE_PASS_MAX_DOFS,
    RATE_MAX,
    RATE_MIN,
    finite,
    parse_groups,
    preset,
    stage_params,
)
from backend.engine.nmf.reference import _reference_step


@functools.cache
def _compiled_steps() -> tuple[Any, Any]:
    """The compiled (passes, one-pass) steps, compiled once per process on first use."""
    return _entry_points()


@dataclass
class FilterResult:
    """Output of `MotionFilter.run`: arrays (T, n) of position, velocity, acceleration and jerk."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray


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

    def __init__(
        self,
        n_dofs: int,
        rate: float,
        order: int = 3,
        sigma: Any = 0.5,
        rho: Any = 0.5,
        vel_limit: Any = 20.0,
        acc_limit: Any = 100.0,
        jerk_limit: Any = 10000.0,
        limiter: str = "tanh",
        bypass: Any = False,
        pmin: Any = None,
        pmax: Any = None,
        beta: Any = 5.0,
        x0: Any = None,
        groups: Sequence[Sequence[int]] | None = None,
        use_numba: bool = True,
    ):
        if isinstance(n_dofs, bool) or not isinstance(n_dofs, numbers.Integral) or n_dofs < 1:
            raise ValueError(f"n_dofs must be a positive integer, got {n_dofs!r}")
        if (
            isinstance(rate, bool)
            or not isinstance(rate, numbers.Real)
            or not RATE_MIN <= float(rate) <= RATE_MAX
        ):
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
        self._groups = parse_groups(groups, self.n)
        self._buf[_GID] = self._groups.gid
        self._buf[_MEMBER] = self._groups.member
        self.groups = self._groups.members
        self.order = 3
        self.limiter = "tanh"
        self.set_params(
            order=order,
            sigma=sigma,
            rho=rho,
            vel_limit=vel_limit,
            acc_limit=acc_limit,
            jerk_limit=jerk_limit,
            limiter=limiter,
            bypass=bypass,
            pmin=pmin,
            pmax=pmax,
            beta=beta,
        )
        self._x0: np.ndarray | None = None
        if x0 is not None:
            self._x0 = finite("x0", x0, self.n)
        self._one_pass = not self._groups.coupled and self.n <= ONE_PASS_MAX_DOFS
        self._bind_step()
        self.reset()

    @classmethod
    def from_preset(
        cls, name: str, n_dofs: int, rate: float, order: int = 3, limiter: str = "tanh", **overrides: Any
    ) -> MotionFilter:
        """A filter with one of the paper's presets W (or "regular"), A, B, C, D, E; overrides win."""
        p = preset(name)
        kw: dict[str, Any] = dict(  # the overrides may be arrays, as the constructor takes them
            sigma=p.sigma,
            rho=p.rho,
            vel_limit=p.vel_limit,
            acc_limit=p.acc_limit,
            jerk_limit=p.jerk_limit,
            bypass=p.bypass,
        )
        kw.update(overrides)
        return cls(n_dofs, rate, order=order, limiter=limiter, **kw)

    # --- configuration ------------------------------------------------------------------------------
    def set_params(
        self,
        *,
        order: int | None = None,
        sigma: Any = None,
        rho: Any = None,
        vel_limit: Any = None,
        acc_limit: Any = None,
        jerk_limit: Any = None,
        limiter: str | None = None,
        bypass: Any = None,
        pmin: Any = None,
        pmax: Any = None,
        beta: Any = None,
        clear_position_limits: bool = False,
    ) -> None:
        """Change parameters live, keeping the filter's state (no jump). Everything is validated
        before anything changes; None leaves a parameter as it is."""
        self._buf[_PARAMS] = stage_params(
            self._buf[_PARAMS],
            self._groups,
            order=order,
            limiter=limiter,
            vel_limit=vel_limit,
            acc_limit=acc_limit,
            jerk_limit=jerk_limit,
            sigma=sigma,
            rho=rho,
            beta=beta,
            bypass=bypass,
            pmin=pmin,
            pmax=pmax,
            clear_position_limits=clear_position_limits,
        )
        if order is not None:
            self.order = int(order)
        if limiter is not None:
            self.limiter = limiter
        self._hard = self.limiter == "hard"
        g = self._groups
        self._cfg[:] = (
            self.dt,
            self.order,
            float(self._hard),
            g.count,
            float(g.coupled),
            float(self._buf[_HASPOS].any()),
            float(np.all(self._buf[_BYPASS] != 0.0)),
            self.rate,
        )

    # --- state ----------------------------------------------------------------------------------------
    def reset(self, x0: Any = None) -> None:
        """Back to rest: x = x0 (or each DoF's first set-point to come), velocity = acceleration = 0."""
        if x0 is not None:
            self._x0 = finite("x0", x0, self.n)
        self._buf[_STATE] = 0.0
        if self._x0 is not None:
            self._buf[_X] = self._x0
            self._buf[_SP] = self._x0
            self._buf[_INIT] = 1.0

    def set_state(self, position: Any, velocity: Any = None, acceleration: Any = None) -> None:
        """Set the filter's state (e.g. to the robot's measured pose) without a jump in the output.
        DoFs without a set-point yet hold `position`."""
        pos = finite("position", position, self.n)
        vel = np.zeros(self.n) if velocity is None else finite("velocity", velocity, self.n)
        acc = np.zeros(self.n) if acceleration is None else finite("acceleration", acceleration, self.n)
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
        return {
            "vel_limit": b[_KV].copy(),
            "acc_limit": b[_KA].copy(),
            "jerk_limit": b[_KJ].copy(),
            "sigma": b[_SIGMA].copy(),
            "rho": b[_RHO].copy(),
            "beta": b[_BETA].copy(),
            "bypass": b[_BYPASS] != 0,
            "pmin": b[_LO].copy(),
            "pmax": b[_HI].copy(),
        }

    @property
    def compiled(self) -> bool:
        """Whether `step` runs the compiled kernels (False: the numpy reference)."""
        return self._use_numba

    def kernel_buffers(self) -> tuple[np.ndarray, np.ndarray, bool]:
        """(state buffer, configuration, one-pass) as the compiled step kernels take them, so a compiled
        caller can step this filter in place (what `step` does, without the Python call)."""
        return self._buf, self._cfg, self._one_pass

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
            passes, one_pass = _compiled_steps()
            kernel = one_pass if self._one_pass else passes
        else:
            kernel = _reference_step
        f64 = np.dtype(np.float64)
        ndarray = np.ndarray

        def fast(setpoints: Any) -> np.ndarray:
            # The common case costs two attribute checks and the compiled call.
            if (
                type(setpoints) is ndarray
                and setpoints.dtype is f64
                and setpoints.shape == shape
                and setpoints.flags.c_contiguous
            ):
                kernel(setpoints, buf, cfg)
                return x
            try:
                arr = np.ascontiguousarray(setpoints, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"setpoints must be numbers (NaN = hold), got {setpoints!r}") from None
            if arr.ndim == 0:
                arr = np.full(n, float(arr))
            if arr.shape != shape:
                raise ValueError(f"setpoints must have shape ({n},), got {arr.shape}")
            if np.isinf(arr).any():
                raise ValueError(f"setpoint of DoF {int(np.flatnonzero(np.isinf(arr))[0])} is infinite")
            kernel(arr, buf, cfg)
            return x

        self._step = fast
        self.step = fast  # instance attribute (the method's signature): skips the method lookup

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
                out[:, k] = self._buf[_X : _JERK + 1]
        return FilterResult(out[0], out[1], out[2], out[3])


def filter_trajectory(setpoints: np.ndarray, rate: float, **kw: Any) -> FilterResult:
    """Convenience: filter a (T,) or (T, n) set-point trajectory with a fresh filter (`preset=` optional)."""
    sps = np.asarray(setpoints, dtype=float)
    one = sps.ndim == 1
    sps2 = sps[:, None] if one else sps
    name = kw.pop("preset", None)
    f = (
        MotionFilter.from_preset(name, sps2.shape[1], rate, **kw)
        if name
        else MotionFilter(sps2.shape[1], rate, **kw)
    )
    res = f.run(sps2)
    if one:
        return FilterResult(res.position[:, 0], res.velocity[:, 0], res.acceleration[:, 0], res.jerk[:, 0])
    return res
