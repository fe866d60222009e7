"""The trajectory-helper (classification and ghost) and `nutty filter` / `nutty figures`."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from backend.cli import main
from backend.engine.trajectory import ACCELERATION, JERK, OK, POSITION, VELOCITY, analyze, ghost, overshoot, settle_time


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


def _read(path):
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def test_filter_cli_samples_irregular_input(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("t,yaw,pitch\n0.0,0,0\n0.33,1,0.5\n0.5,1,-0.5\n1.01,2,0\n")
    out = tmp_path / "out.csv"
    assert main(["filter", str(src), str(out), "--preset", "D", "--rate", "10"]) == 0
    header, data = _read(out)
    assert header == ["t", "yaw", "yaw.vel", "yaw.acc", "yaw.jerk", "pitch", "pitch.vel", "pitch.acc", "pitch.jerk"]
    np.testing.assert_allclose(data[:, 0], np.arange(11) / 10)  # t0 + k/rate up to the last input (floor)
    assert np.isfinite(data).all()
    # hold-latest: before t=0.33 the set-point is 0, so the output stays exactly at rest
    assert (data[:4, 1] == 0).all() and data[4, 1] > 0


def test_filter_cli_matches_the_python_api(tmp_path):
    from backend.engine.nmf import MotionFilter

    t = np.arange(0, 2, 1 / 60)
    sp = np.where(t < 1, 0.0, 3.0)
    src = tmp_path / "in.csv"
    src.write_text("t,x\n" + "".join(f"{a:.10f},{b}\n" for a, b in zip(t, sp)))
    out = tmp_path / "out.csv"
    assert main(["filter", str(src), str(out), "--preset", "B", "--order", "2", "--limiter", "hard",
                 "--sigma", "0.3", "--pmin", "-1", "--pmax", "2.5"]) == 0
    _, data = _read(out)
    f = MotionFilter.from_preset("B", 1, 60, order=2, limiter="hard", sigma=0.3, pmin=-1, pmax=2.5)
    ref = f.run(sp[:, None])
    np.testing.assert_allclose(data[:, 1], ref.position[:, 0], rtol=1e-8, atol=1e-9)
    assert data[:, 1].max() <= 2.5


@pytest.mark.parametrize("content, fragment", [
    ("x,a\n0,1\n", "header must be 't,<name>,...'"),
    ("t,a\n0,1\n0.5,zz\n", "row 3, column 'a': not a number"),
    ("t,a\n1,1\n0.5,2\n", "must be sorted by t"),
    ("t,a\n", "no set-points"),
])
def test_filter_cli_explains_bad_input(tmp_path, capsys, content, fragment):
    src = tmp_path / "in.csv"
    src.write_text(content)
    assert main(["filter", str(src), str(tmp_path / "o.csv")]) == 2
    assert fragment in capsys.readouterr().err


def test_filter_cli_rejects_bad_parameters(tmp_path, capsys):
    src = tmp_path / "in.csv"
    src.write_text("t,a\n0,0\n1,1\n")
    assert main(["filter", str(src), str(tmp_path / "o.csv"), "--sigma", "2"]) == 2
    assert "sigma of DoF 0 must be within [0, 1]" in capsys.readouterr().err


def test_figures_command_draws_every_figure(tmp_path):
    assert main(["figures", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.glob("*.png"))
    assert names == sorted(["nmf_inputs.png", "nmf_h.png", "nmf_omega.png", "nmf_presets_phi_l.png",
                            "nmf_orders.png", "nmf_presets_phi_r.png", "nmf_presets_phi_c.png", "nmf_overview.png"])
    assert all(p.stat().st_size > 20_000 for p in tmp_path.glob("*.png"))
