"""Animation curves: interpolation kinds, handle types, easing presets, vectorised evaluation."""

from __future__ import annotations

import numpy as np
import pytest

from backend.engine.curves import EASINGS, CurveSet, Key, ease, resolve_handles


def sample(keys, ts):
    cs = CurveSet([keys])
    return np.array([cs.evaluate(t)[0] for t in ts])


TS = np.linspace(0.0, 2.0, 401)


def test_constant_steps_and_linear_is_straight():
    steps = sample([Key(0, 0, "constant"), Key(1, 1, "constant"), Key(2, 3)], TS)
    assert set(np.round(steps, 12)) == {0.0, 1.0, 3.0}
    assert steps[TS < 1].max() == 0.0 and steps[(TS >= 1) & (TS < 2)].min() == 1.0
    lin = sample([Key(0, 0, "linear"), Key(2, 4)], TS)
    np.testing.assert_allclose(lin, 2 * TS, atol=1e-12)


def test_keys_are_met_exactly_and_the_curve_holds_outside():
    keys = [Key(0.2, 0.5), Key(0.9, -0.3), Key(1.7, 0.8)]
    cs = CurveSet([keys])
    for k in keys:
        assert cs.evaluate(k.t)[0] == pytest.approx(k.v, abs=1e-9)
    assert cs.evaluate(-1.0)[0] == 0.5 and cs.evaluate(5.0)[0] == 0.8


def test_auto_clamped_never_overshoots_but_auto_may():
    keys = [Key(0, 0, left_type=t, right_type=t) for t in ["auto_clamped"]]
    up_down = lambda kind: [
        Key(0, 0, left_type=kind, right_type=kind),
        Key(0.5, 1.0, left_type=kind, right_type=kind),
        Key(0.6, 1.05, left_type=kind, right_type=kind),
        Key(2.0, 0, left_type=kind, right_type=kind),
    ]
    clamped = sample(up_down("auto_clamped"), TS)
    assert clamped.max() <= 1.05 + 1e-9 and clamped.min() >= -1e-9
    auto = sample(up_down("auto"), TS)
    assert auto.max() > 1.05 + 1e-4  # the free auto tangent overshoots the plateau
    assert keys  # (construction of single-key curves works)


def test_auto_clamped_gives_slow_in_and_out():
    y = sample([Key(0, 0), Key(2, 1)], TS)
    v = np.gradient(y, TS)
    assert v[0] == pytest.approx(0.0, abs=0.02) and v[-1] == pytest.approx(0.0, abs=0.02)
    assert v[200] > 0.6  # fastest in the middle (a linear ramp would be 0.5)


def test_vector_handles_make_straight_segments():
    y = sample(
        [
            Key(0, 0, left_type="vector", right_type="vector"),
            Key(2, 2, left_type="vector", right_type="vector"),
        ],
        TS,
    )
    np.testing.assert_allclose(y, TS, atol=1e-9)


def test_free_handles_author_an_anticipation_dip():
    # a right handle pointing down: the curve first dips below 0 before rising (anticipation)
    keys = [Key(0, 0, right_type="free", right=(0.6, -0.8)), Key(2, 1, left_type="free", left=(-0.3, 0.0))]
    y = sample(keys, TS)
    assert y.min() < -0.1 and np.argmin(y) < 150 and y[-1] == pytest.approx(1.0)


def test_aligned_handle_mirrors_the_direction_of_the_other_side():
    k = Key(1, 0.5, left_type="aligned", right_type="free", right=(0.2, 0.1))
    (lt, lv), (rt, rv) = resolve_handles([Key(0, 0), k, Key(2, 1)])[1]
    assert (lt - 1) < 0 and (rt - 1) > 0
    assert (lv - 0.5) / (lt - 1) == pytest.approx((rv - 0.5) / (rt - 1))  # same slope through the key


def test_handles_are_clamped_in_time_so_the_curve_stays_a_function():
    keys = [Key(0, 0, right_type="free", right=(5.0, 3.0)), Key(1, 1, left_type="free", left=(-5.0, -3.0))]
    (_, (rt, _)), ((lt, _), _) = resolve_handles(keys)
    assert rt <= 1.0 and lt >= 0.0
    y = sample(keys, np.linspace(0, 1, 201))
    assert np.all(np.isfinite(y))


@pytest.mark.parametrize("name", EASINGS)
@pytest.mark.parametrize("mode", ["in", "out", "in_out"])
def test_easings_run_from_0_to_1(name, mode):
    assert ease(name, mode, 0.0) == pytest.approx(0.0, abs=1e-3)
    assert ease(name, mode, 1.0) == pytest.approx(1.0, abs=1e-3)


def test_easing_shapes():
    u = np.linspace(0, 1, 101)
    assert np.all(ease("quad", "in", u) <= u + 1e-12) and np.all(ease("quad", "out", u) >= u - 1e-12)
    assert ease("back", "in", u).min() < -0.05  # anticipation: backs up first
    assert ease("back", "out", u).max() > 1.05  # follow-through: overshoots
    assert ease("elastic", "out", u).max() > 1.1
    bounce = ease("bounce", "out", u)
    assert bounce.max() <= 1.0 + 1e-9 and np.sum(np.diff(np.sign(np.diff(bounce))) != 0) >= 4


def test_an_eased_segment_uses_its_preset():
    y = sample([Key(0, 0, "cubic", easing="in"), Key(2, 1)], TS)
    np.testing.assert_allclose(y, (TS / 2) ** 3, atol=1e-12)


def test_many_curves_evaluate_like_each_alone():
    rng = np.random.default_rng(3)
    curves = []
    for n in range(12):
        times = np.cumsum(rng.uniform(0.1, 0.6, size=rng.integers(1, 7)))
        kinds = ["constant", "linear", "bezier", "sine", "back", "bounce"]
        curves.append(
            [Key(float(t), float(rng.normal()), kinds[(n + i) % len(kinds)]) for i, t in enumerate(times)]
        )
    together = CurveSet(curves)
    for t in np.linspace(-0.2, 4.0, 57):
        alone = [CurveSet([c]).evaluate(t)[0] for c in curves]
        np.testing.assert_allclose(together.evaluate(t), alone, atol=1e-12)


def test_bad_curves_are_refused():
    with pytest.raises(ValueError, match="increase strictly"):
        CurveSet([[Key(1, 0), Key(1, 1)]])
    with pytest.raises(ValueError, match="unknown interpolation"):
        CurveSet([[Key(0, 0, "wobbly"), Key(1, 1)]])
