"""The engine's safety net: the last step before every driver, which no program can remove.

Per continuous DoF channel with finite velocity/acceleration/jerk limits, on the *finite differences*
of the output positions at the engine rate (what a motor sees; dt = 1/rate):

    v_k = (p_k - p_{k-1})/dt,  a_k = (v_k - v_{k-1})/dt,  j_k = (a_k - a_{k-1})/dt

it keeps p in [min, max], |v| <= V, |a| <= A and |j| <= J from any program and any start, and

- **passes the program through bit for bit** when its next sample is reachable within the limits
  and leaves a *viable* state (one from which the DoF can still stop inside its position and
  velocity limits): no lag and no change of character for a program that respects the robot;
- otherwise **corrects**: a discrete-time jerk-limited tracker whose state *is* the output's
  finite-difference state (so the switch between pass-through and correction cannot create a jerk
  the limits do not allow). Far from the program it approaches time-optimally with a braking rule
  (the largest jerk from which it can still brake onto the program without overshoot); near it, a
  receding-horizon plan of N small jerks (the shortest N whose minimum-norm plan fits the jerk
  limit) lands exactly on the program's position, velocity and acceleration, after which the
  program's samples are feasible again and pass through: the net *re-locks*. Every jerk is clipped
  to the interval that keeps the next state within the limits and viable.

Viability is checked with the continuous-time, time-optimal braking profile (ramp the acceleration
down at J, hold at -A, ramp back to 0 at J) plus a margin for the discretisation that vanishes at
rest, so a program holding a DoF at its position limit still passes through exactly.

Coupled groups (a planar base) are limited per axis here; channels without finite limits (LED
colours, enum options) pass through untouched. After the channels, the same tracker runs on the
*joints* the motors receive (a joint's own DoF plus every symbolic DoF driving it), and a joint's
correction is carried back onto its own channel: `backend.engine.joint_net`. Vectorised over
channels: the pass-through test is a handful of numpy operations; the correction is a compiled
(numba) loop over the channels that need it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from backend.engine.embodiment import Embodiment
from backend.engine.joint_net import JointLimits, compose_joints

# The rows of the state and limits arrays, by name.
from backend.engine.net_rows import (
    LIM_A,
    LIM_HI,
    LIM_J,
    LIM_LO,
    LIM_V,
    ROW_A,
    ROW_P,
    ROW_TA,
    ROW_TV,
    ROW_TX,
    ROW_V,
    limit_rows,
    rest_state,
)

#: Relative slack on the limit tests, for floating-point rounding only (not a tolerance on the limits).
EPS = 1e-12
#: Longest receding-horizon plan (s) the net tries before it falls back to the braking approach.
PLAN_SECONDS = 0.4
_BISECT = 40


# --------------------------------------------------------------------------------------------------
# Braking analysis (continuous time, time-optimal), scalar for the compiled correction path
# --------------------------------------------------------------------------------------------------


@njit(cache=True, fastmath=False)
def _stop_up(v: float, a: float, A: float, J: float) -> tuple:
    """Braking upward motion (v, a) as fast as the limits allow: (peak velocity, displacement until the
    motion no longer rises). Assumes a <= A."""
    peak_v = v
    d = 0.0
    if a > 0.0:
        t1 = a / J
        d += v * t1 + a * t1 * t1 / 2.0 - J * t1 * t1 * t1 / 6.0
        v = v + a * a / (2.0 * J)
        peak_v = v
        a = 0.0
    if v > 0.0:
        if a * a / (2.0 * J) >= v:
            disc = a * a - 2.0 * J * v
            t = (-a - math.sqrt(max(disc, 0.0))) / J
            d += v * t + a * t * t / 2.0 + J * t * t * t / 6.0
        else:
            am = math.sqrt((2.0 * J * v + a * a) / 2.0)
            th = 0.0
            if am > A:
                am = A
                th = (v - (2.0 * A * A - a * a) / (2.0 * J)) / A
            ta = (am + a) / J
            d += v * ta + a * ta * ta / 2.0 - J * ta * ta * ta / 6.0
            v += a * ta - J * ta * ta / 2.0
            a = -am
            d += v * th + a * th * th / 2.0
            v += a * th
            tc = am / J
            d += v * tc + a * tc * tc / 2.0 + J * tc * tc * tc / 6.0
    return peak_v, d


@njit(cache=True)
def _stoppable_up(p: float, v: float, a: float, hi: float, V: float, A: float, J: float, h: float) -> bool:
    """The continuous-time braking test with margins for sampling it at the tick rate (they vanish at
    rest): the discrete profile's velocity leads the continuous one by at most one tick of
    acceleration while the deceleration ramps back to 0, which adds at most h·am²/J of travel."""
    if v <= 0.0 and a <= 0.0:  # not rising, and never will while braking: only the bound itself
        return p <= hi
    peak_v, d = _stop_up(v, a, A, J)
    if peak_v + h * max(a, 0.0) > V * (1.0 + EPS):
        return False
    am2 = min(A * A, J * max(v, 0.0) + a * a)
    return p + max(d, 0.0) + h * am2 / J + h * h * abs(a) <= hi


@njit(cache=True)
def _viable_up(p: float, v: float, a: float, hi: float, V: float, A: float, J: float, h: float) -> bool:
    """Whether the DoF can stop rising before `hi` without exceeding +V: the braking test now, or
    after one or two ticks of the hardest braking the limits allow (exact in discrete time), which
    is what a slow approach that ends exactly at the limit needs."""
    for _ in range(3):
        if _stoppable_up(p, v, a, hi, V, A, J, h):
            return True
        a = max(a - h * J, -A)
        v = v + h * a
        p = p + h * v
        if p > hi or v > V * (1.0 + EPS):
            return False
    return False


@njit(cache=True)
def _viable(
    p: float, v: float, a: float, lo: float, hi: float, V: float, A: float, J: float, h: float
) -> bool:
    return _viable_up(p, v, a, hi, V, A, J, h) and _viable_up(-p, -v, -a, -lo, V, A, J, h)


@njit(cache=True)
def _succ(p: float, v: float, a: float, j: float, h: float) -> tuple:
    a1 = a + h * j
    v1 = v + h * a1
    return p + h * v1, v1, a1


@njit(cache=True)
def _largest_viable_jerk(p, v, a, hi, V, A, J, h, j_min, j_max) -> float:
    """The largest jerk in [j_min, j_max] whose next state can still stop rising before `hi` (upper
    viability is lost as the jerk grows); j_min, the hardest braking, when none can."""
    if j_max < j_min:
        return j_min
    p1, v1, a1 = _succ(p, v, a, j_max, h)
    if _viable_up(p1, v1, a1, hi, V, A, J, h):
        return j_max
    p1, v1, a1 = _succ(p, v, a, j_min, h)
    if not _viable_up(p1, v1, a1, hi, V, A, J, h):
        return j_min
    for _ in range(_BISECT):
        mid = 0.5 * (j_min + j_max)
        p1, v1, a1 = _succ(p, v, a, mid, h)
        if _viable_up(p1, v1, a1, hi, V, A, J, h):
            j_min = mid
        else:
            j_max = mid
    return j_min


@njit(cache=True)
def _jerk_interval(p, v, a, lo, hi, V, A, J, h) -> tuple:
    """The jerks allowed next: within ±J and keeping |a| <= A always (hard), and within those, the ones
    whose next state keeps |v| <= V, lo <= p <= hi and stays viable. Returns (j_lo, j_hi); when the
    velocity/position side cannot be met the interval is the hard one's braking end."""
    up_hard = min(J, (A - a) / h)
    dn_hard = max(-J, (-A - a) / h)
    up = min(up_hard, ((V - v) / h - a) / h, (((hi - p) / h - v) / h - a) / h)
    dn = max(dn_hard, ((-V - v) / h - a) / h, (((lo - p) / h - v) / h - a) / h)
    j_hi = _largest_viable_jerk(p, v, a, hi, V, A, J, h, dn_hard, up)
    # The lower side is the upper one mirrored (negation is exact, so the bisection is the same).
    j_lo = -_largest_viable_jerk(-p, -v, -a, -lo, V, A, J, h, -up_hard, -dn)
    if j_lo > j_hi:  # the two sides conflict (a range narrower than the braking allows): split
        mid = min(max(0.5 * (j_lo + j_hi), dn_hard), up_hard)
        return mid, mid
    return j_lo, j_hi


@njit(cache=True)
def _stop_point(e: float, f: float, g: float, A: float, J: float) -> float:
    """Where relative motion (e, f, g) comes to rest under the hardest braking (signed)."""
    g = min(max(g, -A), A)
    if f > 0.0 or (f == 0.0 and g > 0.0):
        return e + _stop_up(f, g, A, J)[1]
    return e - _stop_up(-f, -g, A, J)[1]


@njit(cache=True)
def _approach(e, f, g, A, J, h) -> float:
    """Time-optimal jerk toward relative position 0 from the relative state (e, f, g): as much push
    toward the target as still lets the relative motion brake onto it without overshoot."""
    s = 1.0 if _stop_point(e, f, g, A, J) < 0.0 else -1.0
    # Mirror so that stopping short lies below: maximise u subject to the stop point staying <= 0.
    e, f, g = s * e, s * f, s * g
    lo_u, hi_u = -J, J
    p1, v1, a1 = _succ(e, f, g, hi_u, h)
    if _stop_point(p1, v1, a1, A, J) <= 0.0:
        return s * hi_u
    p1, v1, a1 = _succ(e, f, g, lo_u, h)
    if _stop_point(p1, v1, a1, A, J) > 0.0:
        return s * lo_u
    for _ in range(_BISECT):
        mid = 0.5 * (lo_u + hi_u)
        p1, v1, a1 = _succ(e, f, g, mid, h)
        if _stop_point(p1, v1, a1, A, J) <= 0.0:
            lo_u = mid
        else:
            hi_u = mid
    return s * lo_u


@njit(cache=True)
def _plan(e, f, g, J, h, gains, starts) -> tuple:
    """First jerk of the shortest receding-horizon plan that zeroes the relative state within the jerk
    limit; (found, jerk). `gains` stacks the minimum-norm plans (rows) of every horizon, in scaled units."""
    se, sf, sg = e / (h * h * h), f / (h * h), g / h
    for n in range(len(starts) - 1):
        r0, r1 = starts[n], starts[n + 1]
        fits = True
        for r in range(r0, r1):
            u = gains[r, 0] * se + gains[r, 1] * sf + gains[r, 2] * sg
            if abs(u) > J:
                fits = False
                break
        if fits:
            return True, gains[r0, 0] * se + gains[r0, 1] * sf + gains[r0, 2] * sg
    return False, 0.0


@njit(cache=True)
def _net_step(out, idx, state, limits, locked, corrected, counts, h, gains, starts) -> int:
    """One tick for every governed channel, in place: `out` holds the program's frame and becomes the
    output. Returns how many channels were corrected.

    state rows (per governed channel): p, v, a (the output's finite differences) and tx, tv, ta (the
    program's, clipped to the limits for prediction); limits rows: lo, hi, V, A, J; locked: passed
    through last tick; corrected (per frame channel) and counts (corrections per channel) are written."""
    n_fixed = 0
    for k in range(len(idx)):
        i = idx[k]
        p, v, a = state[ROW_P, k], state[ROW_V, k], state[ROW_A, k]
        lo, hi = limits[LIM_LO, k], limits[LIM_HI, k]
        V, A, J = limits[LIM_V, k], limits[LIM_A, k], limits[LIM_J, k]
        xi = out[i]
        if not math.isfinite(xi):  # a faulty block: hold the last output
            xi = p
        # The program's own finite differences (raw for the lock test, clipped for the tracker).
        rv = (xi - state[ROW_TX, k]) / h
        ra = (rv - state[ROW_TV, k]) / h
        tv = min(max(rv, -V), V)
        ta = min(max(ra, -A), A)
        state[ROW_TX, k], state[ROW_TV, k], state[ROW_TA, k] = xi, tv, ta
        v1 = (xi - p) / h
        a1 = (v1 - v) / h
        j1 = (a1 - a) / h
        ok = (
            abs(j1) <= J * (1.0 + EPS)
            and abs(a1) <= A * (1.0 + EPS)
            and abs(v1) <= V * (1.0 + EPS)
            and lo <= xi <= hi
            and _viable(xi, v1, a1, lo, hi, V, A, J, h)
        )
        if ok and not locked[k]:
            # Re-locking: only once the next predicted sample (the program going on at its present
            # acceleration) is reachable too, so the net does not flicker between the two modes.
            v2 = rv + h * ra
            j2 = ((v2 - v1) / h - a1) / h
            ok = abs(j2) <= 0.5 * J
        if ok:
            new = xi
            corrected[i] = False
        else:
            # The program's motion as a constant-acceleration trajectory through its newest sample,
            # taken back one tick: the relative state the plan must bring to zero.
            e, f, g = p - (xi - h * tv), v - (tv - h * ta), a - ta
            found, j = _plan(e, f, g, J, h, gains, starts)
            if not found:
                j = _approach(e, f, g, A, J, h)
            j_lo, j_hi = _jerk_interval(p, v, a, lo, hi, V, A, J, h)
            j = min(max(j, j_lo), j_hi)
            new, _, _ = _succ(p, v, a, j, h)
            corrected[i] = True
            counts[i] += 1
            n_fixed += 1
        locked[k] = ok
        # The state is the output's own finite differences, computed as a motor's would be.
        nv = (new - p) / h
        state[ROW_A, k] = (nv - v) / h
        state[ROW_V, k] = nv
        state[ROW_P, k] = new
        out[i] = new
    return n_fixed


def plan_horizons(rate: float, seconds: float = PLAN_SECONDS) -> list[int]:
    """Horizons (ticks) the receding-horizon plan tries, shortest first: 3, 4, 5, ... growing by about
    a quarter each, up to `seconds` of ticks (at least 48)."""
    top = max(48, math.ceil(seconds * rate))
    out, n = [], 3
    while n <= top:
        out.append(n)
        n = max(n + 1, round(n * 1.25))
    return out


def plan_gains(horizons: list[int] | int) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-norm jerk plans that bring a triple integrator's scaled state (e/h^3, f/h^2, g/h) to
    rest in n ticks, for each horizon n: rows stacked per horizon, and the row where each starts."""
    if isinstance(horizons, int):
        horizons = list(range(3, horizons + 1))
    F = np.array([[1.0, 1.0, 1.0], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]])  # h = 1 in scaled units
    G = np.array([1.0, 1.0, 1.0])
    rows, starts = [], [0]
    for n in horizons:
        powers = [np.eye(3)]
        for _ in range(n):
            powers.append(F @ powers[-1])
        C = np.stack([powers[n - 1 - i] @ G for i in range(n)], axis=1)  # final state = F^n s + C u
        K = -C.T @ np.linalg.solve(C @ C.T, powers[n])  # (n, 3)
        rows.append(K)
        starts.append(starts[-1] + n)
    return np.ascontiguousarray(np.concatenate(rows)), np.array(starts, dtype=np.int64)


class SafetyNet:
    """The last step before the drivers: enforces each DoF's limits on the output's finite differences.

    `step(target)` takes the program's frame (C,) and returns the frame to send (a new array); the
    channels it had to correct this tick are in `corrected` (bool (C,)), and `corrections` counts the
    ticks each channel was corrected since the start. `enabled=False` passes everything through (the
    explicit, logged `--unsafe-no-limits`).
    """

    def __init__(self, emb: Embodiment, rate: float, enabled: bool = True, start: np.ndarray | None = None):
        self.emb = emb
        self.h = 1.0 / float(rate)
        self.enabled = enabled
        cont = emb.continuous_mask
        finite = np.isfinite(emb.vel_limit) & np.isfinite(emb.acc_limit) & np.isfinite(emb.jerk_limit)
        finite &= (emb.vel_limit > 0) & (emb.acc_limit > 0) & (emb.jerk_limit > 0)
        #: Channels the net governs: continuous, with finite positive limits.
        self.mask = cont & finite
        self.idx = np.flatnonzero(self.mask).astype(np.int64)
        i = self.idx
        #: The limits of the governed channels, by row (`LIM_LO` … `LIM_J`).
        self.limits = limit_rows(
            emb.min[i], emb.max[i], emb.vel_limit[i], emb.acc_limit[i], emb.jerk_limit[i]
        )
        self._gains, self._starts = plan_gains(plan_horizons(rate))
        self.corrections = np.zeros(emb.n_channels, dtype=np.int64)
        self.corrected = np.zeros(emb.n_channels, dtype=bool)
        #: The joint stage: limits per actuated joint, and the joints it steps (`governed`).
        self.joints = JointLimits(emb, self.mask)
        self._jidx = self.joints.governed
        self._jlimits = self.joints.rows()
        #: Corrections per joint since the start, and the joints corrected on the last step.
        self.joint_corrections = np.zeros(len(self.joints.names), dtype=np.int64)
        self.joint_corrected = np.zeros(len(self.joints.names), dtype=bool)
        #: The joint values (rad or m) of the last step's output, in `emb.joint_names` order.
        self.joint_out = np.zeros(len(self.joints.names))
        #: The channels the last step marked corrected for a joint's carried-back correction: the first
        #: `carried_n[0]` of `carried` (cleared by the next step).
        self.carried = np.zeros(emb.n_channels, dtype=np.int64)
        self.carried_n = np.zeros(1, dtype=np.int64)
        #: Counts `reset`s: the state arrays are new after each (backend/engine/frame_tail.py lists them).
        self.generation = 0
        self.corrected_ticks = 0
        #: Whether the last step corrected any channel.
        self.corrected_any = False
        self.reset(emb.rest if start is None else start)

    # The limits of the governed channels (rows of `limits`), by name: position, velocity, acceleration, jerk.
    lo = property(lambda self: self.limits[LIM_LO])
    hi = property(lambda self: self.limits[LIM_HI])
    V = property(lambda self: self.limits[LIM_V])
    A = property(lambda self: self.limits[LIM_A])
    J = property(lambda self: self.limits[LIM_J])

    def reset(self, position: np.ndarray, joints: np.ndarray | None = None) -> None:
        """Start from `position` (C,) at rest (zero velocity and acceleration); `joints` (over
        `emb.joint_names`, NaN: not known) where the joints really stand when the channels cannot say
        (a joint that symbolic DoFs alone drive, measured by a servo), so the joint stage starts there."""
        position = np.asarray(position, dtype=float)
        self.state = rest_state(position[self.idx], self.lo, self.hi)
        self._locked = np.ones(len(self.idx), dtype=bool)
        self.corrected[:] = False
        start = np.array(position)
        start[self.idx] = self.state[ROW_P]
        q = self.joints.compose(start)
        if joints is not None:
            q = np.where(np.isfinite(joints), joints, q)
        jl = self._jlimits
        self._jstate = rest_state(q[self._jidx], jl[LIM_LO], jl[LIM_HI])
        self._jlocked = np.ones(len(self._jidx), dtype=bool)
        self.joint_corrected[:] = False
        self.joint_out = q
        self.carried_n[0] = 0
        self.generation += 1

    @property
    def p(self) -> np.ndarray:
        return self.state[ROW_P]

    @property
    def v(self) -> np.ndarray:
        return self.state[ROW_V]

    @property
    def a(self) -> np.ndarray:
        return self.state[ROW_A]

    def step(self, target: np.ndarray) -> np.ndarray:
        """The frame to send for the program's frame `target` (C,): a new array. The joints it composes
        to are in `joint_out` afterwards."""
        out = np.array(target, dtype=float)
        self.corrected_any = False
        n = self.carried_n[0]
        if n:  # last step's carried-back joint corrections
            self.corrected[self.carried[:n]] = False
            self.carried_n[0] = 0
        if not self.enabled:
            self.joint_out = self.joints.compose(out)
            return out
        fixed = 0
        if len(self.idx):
            fixed = _net_step(
                out,
                self.idx,
                self.state,
                self.limits,
                self._locked,
                self.corrected,
                self.corrections,
                self.h,
                self._gains,
                self._starts,
            )
        j = self.joints
        q = np.empty(len(j.names))
        compose_joints(out, j.starts, j.cols, j.coefs, j.offset, q)
        if len(self._jidx):
            composed = q[self._jidx]
            if _net_step(
                q,
                self._jidx,
                self._jstate,
                self._jlimits,
                self._jlocked,
                self.joint_corrected,
                self.joint_corrections,
                self.h,
                self._gains,
                self._starts,
            ):
                fixed += 1
                self._carry_back(out, q, composed)
        self.joint_out = q
        if fixed:
            self.corrected_ticks += 1
            self.corrected_any = True
        return out

    def _carry_back(self, out: np.ndarray, q: np.ndarray, composed: np.ndarray) -> None:
        """Move each corrected joint's correction onto its own channel (joints without one keep theirs in
        `joint_out` only), and mark that channel corrected."""
        g = self._jidx
        hit = self.joint_corrected[g] & (self.joints.own[g] >= 0)
        if hit.any():
            own = self.joints.own[g][hit]
            out[own] += q[g][hit] - composed[hit]
            self.corrected[own] = True
            self.carried[: len(own)] = own
            self.carried_n[0] = len(own)

    def stats(self) -> dict:
        names = self.emb.channel_names
        joints = self.joints.names
        return {
            "enabled": self.enabled,
            "corrected_ticks": int(self.corrected_ticks),
            "corrections": {names[i]: int(self.corrections[i]) for i in np.flatnonzero(self.corrections)},
            "correcting": [names[i] for i in np.flatnonzero(self.corrected)],
            "joint_corrections": {
                joints[i]: int(self.joint_corrections[i]) for i in np.flatnonzero(self.joint_corrections)
            },
            "joints_correcting": [joints[i] for i in np.flatnonzero(self.joint_corrected)],
            "joints_governed": [joints[i] for i in self._jidx],
        }
