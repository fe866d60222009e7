"""`nutty filter` and `nutty figures`: CSV in, filtered CSV out; the paper's figures."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from backend.cli import main
from backend.engine.nmf import MotionFilter


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
    assert header == [
        "t",
        "yaw",
        "yaw.vel",
        "yaw.acc",
        "yaw.jerk",
        "pitch",
        "pitch.vel",
        "pitch.acc",
        "pitch.jerk",
    ]
    np.testing.assert_allclose(data[:, 0], np.arange(11) / 10)  # t0 + k/rate up to the last input (floor)
    assert np.isfinite(data).all()
    # hold-latest: before t=0.33 the set-point is 0, so the output stays exactly at rest
    assert (data[:4, 1] == 0).all() and data[4, 1] > 0


def test_filter_cli_matches_the_python_api(tmp_path):
    t = np.arange(0, 2, 1 / 60)
    sp = np.where(t < 1, 0.0, 3.0)
    src = tmp_path / "in.csv"
    src.write_text("t,x\n" + "".join(f"{a:.10f},{b}\n" for a, b in zip(t, sp)))
    out = tmp_path / "out.csv"
    assert (
        main(
            [
                "filter",
                str(src),
                str(out),
                "--preset",
                "B",
                "--order",
                "2",
                "--limiter",
                "hard",
                "--sigma",
                "0.3",
                "--pmin",
                "-1",
                "--pmax",
                "2.5",
            ]
        )
        == 0
    )
    _, data = _read(out)
    f = MotionFilter.from_preset("B", 1, 60, order=2, limiter="hard", sigma=0.3, pmin=-1, pmax=2.5)
    ref = f.run(sp[:, None])
    np.testing.assert_allclose(data[:, 1], ref.position[:, 0], rtol=1e-8, atol=1e-9)
    assert data[:, 1].max() <= 2.5


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("x,a\n0,1\n", "header must be 't,<name>,...'"),
        ("t,a\n0,1\n0.5,zz\n", "row 3, column 'a': not a number"),
        ("t,a\n1,1\n0.5,2\n", "must be sorted by t"),
        ("t,a\n", "no set-points"),
    ],
)
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
    assert names == sorted(
        [
            "nmf_inputs.png",
            "nmf_h.png",
            "nmf_omega.png",
            "nmf_presets_phi_l.png",
            "nmf_orders.png",
            "nmf_presets_phi_r.png",
            "nmf_presets_phi_c.png",
            "nmf_overview.png",
        ]
    )
    assert all(p.stat().st_size > 20_000 for p in tmp_path.glob("*.png"))


def test_filter_cli_sample_times_survive_decimal_rounding(tmp_path):
    # 0.1 + 0.2 is written as 0.30000000000000004: the input still counts at the sample t = 0.3,
    # and the last input time (0.7, i.e. 6.999... samples of 0.1 s) is still a sample.
    src = tmp_path / "in.csv"
    src.write_text(f"t,a\n0,0\n{0.1 + 0.2!r},1\n0.7,2\n")
    out = tmp_path / "out.csv"
    assert (
        main(
            [
                "filter",
                str(src),
                str(out),
                "--rate",
                "10",
                "--preset",
                "W",
                "--order",
                "1",
                "--limiter",
                "hard",
                "--vel",
                "1000",
            ]
        )
        == 0
    )
    _, data = _read(out)
    np.testing.assert_allclose(data[:, 0], np.arange(8) / 10)
    # W, order 1, hard, V large: the output reaches each set-point at its own sample
    np.testing.assert_array_equal(data[:, 1], [0, 0, 0, 1, 1, 1, 1, 2])


def test_filter_cli_empty_cell_holds_that_dof(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("t,a,b\n0,0,\n0.5,,3\n1.0,1,\n")  # b has no set-point until t = 0.5
    out = tmp_path / "out.csv"
    assert main(["filter", str(src), str(out), "--rate", "10", "--preset", "D"]) == 0
    _, data = _read(out)
    ref = MotionFilter.from_preset("D", 2, 10).run(np.array([[0, np.nan]] * 5 + [[0, 3]] * 5 + [[1, 3]]))
    np.testing.assert_array_equal(data[:, 1], ref.position[:, 0])
    np.testing.assert_array_equal(data[:, 5], ref.position[:, 1])
    assert (data[:5, 5] == 0).all() and data[5, 5] == 3.0  # waits, then starts at its first set-point


def test_filter_cli_sigma_switches_h_on_without_a_preset(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("t,a\n0,0\n0.1,5\n2,5\n")
    plain, shaped = tmp_path / "w.csv", tmp_path / "s.csv"
    assert main(["filter", str(src), str(plain)]) == 0
    assert main(["filter", str(src), str(shaped), "--sigma", "1", "--rho", "1"]) == 0
    w, s = _read(plain)[1][:, 1], _read(shaped)[1][:, 1]
    ref = MotionFilter.from_preset("A", 1, 60).run(np.r_[np.zeros(6), np.full(115, 5.0)]).position[:, 0]
    np.testing.assert_array_equal(s, ref)  # W's limits with σ = ρ = 1: preset A
    assert not np.array_equal(w, s)


def test_filter_cli_output_is_exact_and_derivatives_consistent(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("t,x\n0,0\n0.2,1\n0.6,-1\n1.5,0\n")
    out = tmp_path / "out.csv"
    assert main(["filter", str(src), str(out), "--preset", "C", "--rate", "100"]) == 0
    header, data = _read(out)
    assert header == ["t", "x", "x.vel", "x.acc", "x.jerk"]
    assert len(data) == 151
    # velocity is the finite difference of the written positions (written with exact decimals)
    np.testing.assert_allclose(np.diff(data[:, 1]) * 100, data[1:, 2], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.diff(data[:, 3]) * 100, data[1:, 4], rtol=1e-9, atol=1e-6)


def test_filter_cli_missing_file_and_bad_options(tmp_path, capsys):
    assert main(["filter", str(tmp_path / "nope.csv"), str(tmp_path / "o.csv")]) == 2
    assert "cannot read" in capsys.readouterr().err
    src = tmp_path / "in.csv"
    src.write_text("t,a\n0,0\n1,1\n")
    assert main(["filter", str(src), str(tmp_path / "o.csv"), "--preset", "Q"]) == 2
    assert "unknown preset 'Q'" in capsys.readouterr().err
    assert main(["filter", str(src), str(tmp_path / "o.csv"), "--rate", "0"]) == 2
    assert "--rate must be" in capsys.readouterr().err
    assert main(["filter", str(src), str(tmp_path / "o.csv"), "--pmin", "0"]) == 2
    assert "pmin and pmax must be given together" in capsys.readouterr().err
    assert main(["filter", str(src), str(tmp_path / "no" / "dir" / "o.csv")]) == 2
    assert "cannot write" in capsys.readouterr().err


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("t,a,a\n0,1,2\n", "repeated column names in header: a"),
        ("t,a\n0,1\n\n0.5,1,2\n", "row 4 has 3 cells"),
        ("t,a\n0,1\n0.5,inf\n", "row 3, column 'a': value must be finite"),
        ("t,a\n0,1\n\n2,1\n1,1\n", "row 5 (t=1) goes back in time"),
    ],
)
def test_filter_cli_names_row_and_column(tmp_path, capsys, content, fragment):
    src = tmp_path / "in.csv"
    src.write_text(content)
    assert main(["filter", str(src), str(tmp_path / "o.csv")]) == 2
    assert fragment in capsys.readouterr().err
