"""The Nutty Motion Filter: single steps against hand-computed values, presets as the paper reports,
compiled kernel == numpy reference, run == step, parameter validation, coupled groups."""

from __future__ import annotations

import math

import numpy as np
import pytest

from backend.engine import nmf_examples as ex
from backend.engine.nmf import PRESETS, MotionFilter, h_gain, lam, omega, pow_np, stabilise, tanh_np
from backend.engine.trajectory import overshoot, settle_time

DT = 1 / 60


def test_limiters():
    assert lam(1000.0, 20.0) == pytest.approx(10.0)  # tanh: headroom k/2
    assert lam(1.0, 20.0) == pytest.approx(10 * math.tanh(0.1))
    assert lam(1000.0, 20.0, hard=True) == 20.0
    assert lam(-5.0, 20.0, hard=True) == -5.0


def test_omega_fades_toward_limits_only():
    # Pmin=-10, Pmax=20: centre 5, alpha 15; at x=12.5 (half-way to the top), beta=1: factor 1-0.5^2
    assert omega(2.0, 12.5, -10, 20, 1) == pytest.approx(2.0 * 0.75)
    assert omega(-2.0, 12.5, -10, 20, 1) == -2.0  # moving away from the limit: untouched
    assert omega(2.0, 20.0, -10, 20, 5) == 0.0
    assert omega(-3.0, -2.5, -10, 20, 2) == pytest.approx(-3.0 * (1 - 0.5**4))


def test_h_at_known_points():
    # sigma=1: (|v|/(1-rho))^0 = 1 for every v (0^0 = 1): H(v) = v (tanh(1-pi)+1)/2
    g = 0.5 * (math.tanh(1 - math.pi) + 1)
    assert stabilise(7.0, 1.0, 0.3) == pytest.approx(7.0 * g)
    assert stabilise(0.0, 1.0, 1.0) == 0.0
    assert stabilise(0.0, 0.0, 0.0) == 0.0
    # sigma=0, rho=0: gain (tanh(|v| - pi) + 1)/2
    assert stabilise(3.0, 0.0, 0.0) == pytest.approx(3.0 * 0.5 * (math.tanh(3.0 - math.pi) + 1))
    # rho = 1 is clamped to 0.999
    assert stabilise(1.0, 0.5, 1.0) == pytest.approx(0.5 * (math.tanh((1 / 0.001) ** 0.5 - math.pi) + 1))
    for s in (0.0, 0.5, 1.0):
        for r in (0.0, 0.5, 1.0):
            assert np.isfinite(h_gain(np.array([0.0, 1e-300, 1e300]), s, r)).all()


def _one(order, limiter="tanh", **kw):
    base = dict(sigma=0.5, rho=0.5, vel_limit=20.0, acc_limit=100.0, jerk_limit=10000.0)
    base.update(kw)
    return MotionFilter(1, 60, order=order, limiter=limiter, x0=0.0, **base)


@pytest.mark.parametrize("use_numba", [True, False])
def test_first_steps_by_hand(use_numba):
    s, sig, rho = 1.0, 0.5, 0.5
    v = (s - 0.0) / DT
    u = v * 0.5 * (math.tanh((abs(v) / (1 - rho)) ** (1 - sig) - math.pi) + 1)
    # order 1
    f = _one(1, use_numba=use_numba)
    f.step(np.array([s]))
    vel = 10 * math.tanh(u / 10)
    assert f.velocity[0] == pytest.approx(vel)
    assert f.position[0] == pytest.approx(vel * DT)
    # order 2
    f = _one(2, use_numba=use_numba)
    f.step(np.array([s]))
    acc = 50 * math.tanh((u / DT) / 50)
    vel = 10 * math.tanh(acc * DT / 10)
    assert f.velocity[0] == pytest.approx(vel)
    assert f.acceleration[0] == pytest.approx(vel / DT)  # reported as (vel' - vel)/dt
    # order 3, two steps
    f = _one(3, use_numba=use_numba)
    f.step(np.array([s]))
    jerk = 5000 * math.tanh(((u / DT) / DT) / 5000)
    acc = 50 * math.tanh(jerk * DT / 50)
    vel = 10 * math.tanh(acc * DT / 10)
    x = vel * DT
    assert (f.position[0], f.velocity[0], f.acceleration[0]) == pytest.approx((x, vel, acc))
    f.step(np.array([s]))
    v2 = (s - x) / DT
    u2 = v2 * 0.5 * (math.tanh((abs(v2) / (1 - rho)) ** (1 - sig) - math.pi) + 1)
    jerk2 = 5000 * math.tanh((((u2 - vel) / DT) - acc) / DT / 5000)
    acc2 = 50 * math.tanh((acc + jerk2 * DT) / 50)
    vel2 = 10 * math.tanh((vel + acc2 * DT) / 10)
    assert f.position[0] == pytest.approx(x + vel2 * DT)
    assert f.jerk[0] == pytest.approx((acc2 - acc) / DT)


def test_hard_limiter_and_bypass_by_hand():
    f = _one(1, limiter="hard", bypass=True)
    f.step(np.array([1.0]))  # v = 60 > V = 20: clipped to 20
    assert f.velocity[0] == 20.0
    assert f.position[0] == pytest.approx(20.0 * DT)


def test_position_clip_zeroes_velocity_and_acceleration():
    f = MotionFilter(
        1, 60, order=1, bypass=True, limiter="hard", vel_limit=1000, pmin=-1, pmax=1, x0=0.9, beta=1e9
    )  # beta huge: Ω is ~identity until the very edge
    f.step(np.array([5.0]))
    assert f.position[0] == 1.0
    assert f.velocity[0] == 0.0 and f.acceleration[0] == 0.0


def test_nan_setpoint_holds_latest():
    f = MotionFilter.from_preset("D", 2, 60)
    f.step(np.array([1.0, 2.0]))
    f.step(np.array([np.nan, 3.0]))
    np.testing.assert_array_equal(f.setpoint, [1.0, 3.0])
    g = MotionFilter.from_preset("D", 1, 60)
    g.step(np.array([np.nan]))  # not yet initialised: stays at 0, no NaN
    assert g.position[0] == 0.0 and np.isfinite(g.velocity).all()


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("limiter", ["tanh", "hard"])
@pytest.mark.parametrize("name", list(PRESETS))
@pytest.mark.parametrize("layout", ["few", "many", "grouped"])  # one-pass kernel, passes, coupled passes
def test_compiled_kernel_equals_numpy_reference_and_run_equals_step(order, limiter, name, layout):
    x = np.concatenate(
        [np.stack([ex.phi_l(), ex.phi_r(), ex.phi_c()], axis=1)] * (1 if layout == "few" else 3), axis=1
    )
    x = x[::2]  # 5 s at 60 Hz: every step of the inputs, half the time (the numpy reference is slow)
    x[::7, 1] = np.nan  # "no new set-point" every 7th sample on one DoF
    n = x.shape[1]
    kw = dict(order=order, limiter=limiter, pmin=-8, pmax=8)
    if layout == "grouped":
        kw["groups"] = [[0, 1], [3, 4, 5]]
    fast = MotionFilter.from_preset(name, n, 60, **kw)
    ref = MotionFilter.from_preset(name, n, 60, use_numba=False, **kw)
    stepper = MotionFilter.from_preset(name, n, 60, **kw)
    batch, oracle = fast.run(x), ref.run(x)
    # the same operations in the same order. LLVM may fuse a*b+c into one FMA in the compiled kernel,
    # which rounds once instead of twice (numba 0.68 does); the filter's recursion carries such last-bit
    # differences on, so the two agree to 1e-11 relative, not bit for bit
    for q in ("position", "velocity", "acceleration", "jerk"):
        ref_q = getattr(oracle, q)
        np.testing.assert_allclose(
            getattr(batch, q), ref_q, rtol=1e-11, atol=1e-11 * np.abs(ref_q).max(), err_msg=q
        )
    np.testing.assert_array_equal(np.array([stepper.step(row).copy() for row in x]), batch.position)
    np.testing.assert_array_equal(stepper.jerk, batch.jerk[-1])


def test_own_tanh_is_within_4_ulp_of_libm():
    rng = np.random.default_rng(3)
    x = np.concatenate(
        [
            rng.uniform(-25, 25, 200_000),
            rng.normal(0, 1e-3, 10_000),
            np.logspace(-300, 2, 3000),
            [0.0, 19.0, 20.0, 21.0, 1e300, -1e300],
        ]
    )
    got = tanh_np(x)
    want = np.tanh(x)
    ulp = np.abs(got - want) / np.spacing(np.maximum(np.abs(want), np.finfo(float).tiny))
    assert ulp.max() <= 4
    assert (np.abs(got) <= 1.0).all() and got[-2] == 1.0 and got[-1] == -1.0


def test_own_power_is_within_2e_13_of_libm():
    rng = np.random.default_rng(4)
    b = np.concatenate(
        [
            10.0 ** rng.uniform(-300, 12, 100_000),
            [5e-324, 1e-310, 2.0**-500, 1.0, 1e12, math.sqrt(2), math.sqrt(2) - 1e-16],
        ]
    )
    e = rng.uniform(0.0, 1.0, b.size)
    e[:500] = 1e-12
    want = b**e
    got = pow_np(b, e)
    ok = want > 1e-290  # below, e ln b < -700 is clamped: the result is < 1e-304 either way
    assert (np.abs(got - want)[ok] <= 2e-13 * want[ok]).all()
    assert (got[~ok] < 1e-290).all()
    assert pow_np(np.array([0.0]), np.array([0.5]))[0] == 0.0


def test_omega_and_h_inside_one_step_by_hand():
    # order 1, hard limiter with a huge V: the step is x' = x + H(Ω(v)) dt exactly as in the spec
    x0, s, rate = 6.0, 9.0, 50.0
    f = MotionFilter(
        1, rate, order=1, limiter="hard", vel_limit=1e9, sigma=1.0, rho=0.0, pmin=-10, pmax=10, beta=2, x0=x0
    )
    f.step(np.array([s]))
    v = (s - x0) * rate * (1 - (x0 / 10) ** 4)  # centre 0, alpha 10, 2 beta = 4
    u = v * 0.5 * (math.tanh(1.0 - math.pi) + 1)  # sigma = 1: the power is 1 for every v
    assert f.velocity[0] == pytest.approx(u, rel=1e-14)
    assert f.position[0] == pytest.approx(x0 + u / rate, rel=1e-14)
    # moving away from the nearer limit: Ω leaves v alone
    g = MotionFilter(1, rate, order=1, limiter="hard", vel_limit=1e9, bypass=True, pmin=-10, pmax=10, x0=x0)
    g.step(np.array([0.0]))
    assert g.velocity[0] == pytest.approx(-x0 * rate, rel=1e-14)


def _phi_l(name, limiter="tanh", order=3):
    return (
        MotionFilter.from_preset(name, 1, 60, order=order, limiter=limiter)
        .run(ex.phi_l()[:, None])
        .position[:, 0]
    )


def test_presets_behave_as_the_paper_reports():
    first = slice(150, 450)  # the -5 plateau of Φ_L: the response to the 5 -> -5 step
    a, d = _phi_l("A")[first], _phi_l("D")[first]
    # A is slower than D: D settles near -5 well before A does
    assert settle_time(d, -5.0, 60, 0.1) < settle_time(a, -5.0, 60, 0.1)
    assert a[-1] > -4.9  # A is slow to settle: not there after 5 s
    # hard-limited W overshoots more than tanh W
    assert overshoot(_phi_l("W", "hard")[first], 5, -5) > 2 * overshoot(_phi_l("W", "tanh")[first], 5, -5)
    # C (fast & vivid) overshoots more than B (slow & vivid), and B has a small bump
    ob, oc = overshoot(_phi_l("B")[first], 5, -5), overshoot(_phi_l("C")[first], 5, -5)
    assert 0.05 < ob < oc
    # D: nearly none
    assert overshoot(d, 5, -5) < 0.02


def test_a_sustains_low_speed_far_below_its_limit():
    f = MotionFilter.from_preset("A", 1, 60)
    res = f.run(ex.phi_l()[:, None])
    peak = np.abs(res.velocity).max()
    assert 3.0 < peak < 8.0  # the paper: sustained speed about 5 for a limit of 20


def test_lower_order_higher_sustained_velocity():
    peaks = [
        np.abs(MotionFilter.from_preset("W", 1, 60, order=o).run(ex.phi_l()[:, None]).velocity).max()
        for o in (1, 2, 3)
    ]
    assert peaks[0] > peaks[1] >= peaks[2] - 1e-9


def test_coupled_group_limits_vector_norm():
    f = MotionFilter(3, 100, order=1, bypass=True, vel_limit=1.0, groups=[[0, 1]], x0=0.0)
    for _ in range(50):
        f.step(np.array([10.0, 10.0, 10.0]))
        v = f.velocity
        assert math.hypot(v[0], v[1]) <= 0.5 + 1e-12  # tanh headroom V/2 on the norm
        assert v[0] == pytest.approx(v[1])  # direction kept
    assert v[2] == pytest.approx(0.5, abs=1e-6)  # the ungrouped DoF gets the full V/2 alone


def test_set_params_live_keeps_state():
    f = MotionFilter.from_preset("D", 1, 60)
    for _ in range(30):
        f.step(np.array([1.0]))
    before = (f.position.copy(), f.velocity.copy())
    f.set_params(sigma=0.2, rho=0.1)
    np.testing.assert_array_equal(f.position, before[0])
    np.testing.assert_array_equal(f.velocity, before[1])
    assert f.params()["sigma"][0] == 0.2


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(jerk_limit=[1, 1, -1]), "jerk_limit of DoF 2 must be > 0"),
        (dict(vel_limit=float("inf")), "vel_limit of DoF 0 must be > 0 and finite"),
        (dict(sigma=[0.5, 1.5, 0.5]), "sigma of DoF 1 must be within [0, 1]"),
        (dict(rho=-0.1), "rho of DoF 0 must be within [0, 1]"),
        (dict(pmin=1.0, pmax=[2, 0.5, 2]), "pmin of DoF 1 must be below pmax"),
        (dict(pmin=1.0), "pmin and pmax must be given together"),
        (dict(beta=0.5), "beta of DoF 0 must be >= 1"),
        (dict(order=4), "order must be 1, 2 or 3"),
        (dict(limiter="soft"), "limiter must be 'tanh' or 'hard'"),
        (dict(acc_limit=[1, 2]), "acc_limit must be a scalar or have one value per DoF (3)"),
        (dict(groups=[[0, 5]]), "groups[0] names DoF 5"),
        (dict(groups=[[0, 1]], vel_limit=[1, 2, 3]), "equal within a coupled group"),
    ],
)
def test_bad_parameters_name_parameter_and_dof(kw, message):
    with pytest.raises(ValueError) as err:
        MotionFilter(3, 60, **kw)
    assert message in str(err.value)


def test_more_validation_messages():
    with pytest.raises(ValueError, match=r"rate must be a number of Hz in \[0.001, 1e\+06\]"):
        MotionFilter(1, 0)
    with pytest.raises(ValueError, match="n_dofs must be a positive integer"):
        MotionFilter(0, 60)
    with pytest.raises(ValueError, match="vel_limit of DoF 1 must be <= 1e\\+100"):
        MotionFilter(2, 60, vel_limit=[1.0, 1e200])
    with pytest.raises(ValueError, match="sigma must be equal within a coupled group"):
        MotionFilter(3, 60, sigma=[0.1, 0.2, 0.3], groups=[[0, 1]])
    with pytest.raises(ValueError, match="x0 of DoF 1 must be finite"):
        MotionFilter(2, 60, x0=[0.0, np.nan])
    f = MotionFilter(2, 60)
    with pytest.raises(ValueError, match="velocity of DoF 0 must be finite"):
        f.set_state([0.0, 0.0], velocity=[np.inf, 0.0])
    with pytest.raises(ValueError, match=r"setpoints must have shape \(2,\)"):
        f.step([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="setpoint of DoF 1 is infinite"):
        f.step([1.0, np.inf])
    before = f.params()
    with pytest.raises(ValueError, match="rho of DoF 0"):
        f.set_params(sigma=0.9, rho=2.0)  # nothing changes when a check fails
    assert f.params()["sigma"][0] == before["sigma"][0]


def test_per_dof_parameters_and_bypass():
    # DoF 0 bypassed (W), DoF 1 preset A's character: same limits, different motion
    f = MotionFilter(2, 60, sigma=[0.5, 1.0], rho=[0.5, 1.0], bypass=[True, False], x0=0.0)
    res = f.run(np.tile([5.0, 5.0], (120, 1)))
    w = MotionFilter.from_preset("W", 1, 60, x0=0.0).run(np.full((120, 1), 5.0)).position[:, 0]
    a = MotionFilter.from_preset("A", 1, 60, x0=0.0).run(np.full((120, 1), 5.0)).position[:, 0]
    np.testing.assert_array_equal(res.position[:, 0], w)
    np.testing.assert_array_equal(res.position[:, 1], a)


def test_infinite_position_bound_clips_only_the_finite_side():
    f = MotionFilter(
        1, 60, order=1, bypass=True, limiter="hard", vel_limit=1000, pmin=-np.inf, pmax=1.0, x0=0.0
    )
    f.step(np.array([5.0]))
    assert f.position[0] == 1.0 and f.velocity[0] == 0.0
    f.step(np.array([-50.0]))
    assert f.position[0] == pytest.approx(1.0 - 1000 / 60)


def test_uninitialised_dof_waits_at_x0_or_zero():
    f = MotionFilter(2, 60, x0=None)
    f.step(np.array([np.nan, 3.0]))
    np.testing.assert_array_equal(f.position, [0.0, 3.0])  # DoF 1 starts at its first set-point
    f.step(np.array([2.0, np.nan]))
    assert f.position[0] == 2.0  # and DoF 0 at its own first one, without a jump from 0
    g = MotionFilter(1, 60, x0=1.5)
    g.step(np.array([np.nan]))
    assert g.position[0] == 1.5 and g.velocity[0] == 0.0


def test_reset_and_set_state():
    f = MotionFilter.from_preset("D", 1, 60)
    first = f.run(np.full((30, 1), 2.0)).position.copy()
    f.reset()
    np.testing.assert_array_equal(f.run(np.full((30, 1), 2.0)).position, first)
    f.set_state([1.0], velocity=[3.0], acceleration=[-2.0])
    assert (f.position[0], f.velocity[0], f.acceleration[0]) == (1.0, 3.0, -2.0)
    f.step(np.array([np.nan]))  # holds the latest set-point (2.0) and continues from the new state
    assert f.position[0] > 1.0


def test_unknown_preset():
    with pytest.raises(ValueError, match="unknown preset 'Z'"):
        MotionFilter.from_preset("Z", 1, 60)
    assert MotionFilter.from_preset("regular", 1, 60).params()["bypass"][0]
