"""The trajectory-helper: classification of limit violations, the ghost, motion-quality metrics."""

from __future__ import annotations

import numpy as np
import pytest

from backend.engine.trajectory import (
    ACCELERATION,
    JERK,
    OK,
    POSITION,
    VELOCITY,
    analyze,
    ghost,
    overshoot,
    settle_time,
    step_metrics,
)


def test_classification_most_severe_wins():
    rate = 10.0
    x = np.array([0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])  # one step of 1 in 0.1 s
    res = analyze(x, rate, vel_limit=5.0, acc_limit=1000.0, jerk_limit=1e9)
    assert res.classes[4, 0] == VELOCITY  # 10/s > 5/s
    res = analyze(x, rate, vel_limit=50.0, acc_limit=50.0, jerk_limit=1e9)
    assert res.classes[4, 0] == ACCELERATION and res.classes[5, 0] == ACCELERATION  # +100 then -100
    res = analyze(x, rate, vel_limit=5.0, acc_limit=50.0, jerk_limit=100.0)
    assert res.classes[4, 0] == JERK
    assert res.classes[0, 0] == OK and res.classes[-1, 0] == OK
    res = analyze(x, rate, 1e9, 1e9, 1e9, pmin=-0.5, pmax=0.5)
    assert (res.classes[4:, 0] == POSITION).all()
    assert res.counts()["position"] == 6


def test_ghost_of_a_step_respects_limits():
    rate = 60.0
    x = np.r_[np.zeros(30), np.full(400, 2.0)]
    g = ghost(x, rate, preset="D")
    res = analyze(g, rate, vel_limit=90, acc_limit=700, jerk_limit=50000 * 1.01)
    assert res.ok
    assert not analyze(x, rate, 90, 700, 50000).ok  # the authored step itself breaks every limit
    assert abs(g[-1] - 2.0) < 1e-3


def test_metrics():
    r = np.array([0.0, 0.5, 1.2, 0.95, 1.0, 1.0])
    assert overshoot(r, 0.0, 1.0) == pytest.approx(0.2)
    assert overshoot(-r, 0.0, -1.0) == pytest.approx(0.2)
    assert settle_time(r, 1.0, 10.0, 0.1) == pytest.approx(0.3)
    assert settle_time(np.array([0.0, 0.0]), 1.0, 10.0, 0.1) == float("inf")


def test_step_metrics_per_step():
    rate = 10.0
    sp = np.r_[np.zeros(5), np.ones(10), np.zeros(10)]
    y = np.r_[
        np.zeros(5),
        [0.5, 1.2, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        [0.6, 0.3, -0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ]
    m = step_metrics(sp, y, rate)
    assert m.overshoot == pytest.approx([0.2, 0.1])
    assert m.settle == pytest.approx([0.2, 0.3])
    assert m.max_overshoot == pytest.approx(0.2) and m.settled == 2
    assert m.rms_error == pytest.approx(np.sqrt(np.mean((y - sp) ** 2)))


def test_analyze_validates_its_arguments():
    with pytest.raises(ValueError, match="jerk_limit of DoF 1 must be > 0"):
        analyze(np.zeros((5, 2)), 60, 1.0, 1.0, [1.0, 0.0])
    with pytest.raises(ValueError, match="rate must be a positive number"):
        analyze(np.zeros(5), 0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="vel_limit must be a scalar or have one value per DoF"):
        analyze(np.zeros((5, 2)), 60, [1.0, 1.0, 1.0], 1.0, 1.0)
    assert analyze(np.zeros((5, 2)), 60, np.inf, np.inf, np.inf).ok  # inf: unlimited


def test_colours_for_every_class():
    from backend.engine.trajectory import CLASS_COLOURS, CLASS_NAMES

    assert set(CLASS_COLOURS) == set(CLASS_NAMES.values())
    assert all(c.startswith("#") and len(c) == 7 for c in CLASS_COLOURS.values())
