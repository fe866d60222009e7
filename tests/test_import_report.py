"""The import report: swing per mapped channel and its warnings, the trajectory-helper on every import
(samples over the velocity/acceleration/jerk limits, the slow-down that fits, the NMF preset that keeps
the shape), --fit-limits, --json; plus the rotation maths behind it."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from test_import import G, GltfBuilder, qa, urdf_axis
from test_import_bvh import RATE, motion, write_bvh

from backend.cli import main
from backend.engine import trajectory
from backend.importers import hermite_keys, import_clip
from backend.importers.limits import analyse_clip, sampler
from backend.importers.rotations import (
    axis_conversion,
    davenport,
    principal_axis,
    quat_axis_angle,
    quat_from_matrix,
    quat_mul,
    quat_to_matrix,
    slerp,
)


def nutty(capsys, *argv) -> tuple[int, str, str]:
    code = main(["import", *[str(a) for a in argv]])
    out, err = capsys.readouterr()
    return code, out, err


def test_gltf_swing_warning_names_channel_and_axis(tmp_path, capsys):
    """A head_yaw node that mostly rolls: the twist about Z keeps little; the warning suggests the
    roll axis and the DoF that turns about it."""
    b = GltfBuilder()
    n = b.node("head_yaw")
    t = np.linspace(0, 1, 11)
    q = quat_mul(
        qa(G([0, 0, 1]), 0.1 * np.sin(2 * np.pi * t)), qa(G([1, 0, 0]), 0.35 * np.sin(2 * np.pi * t))
    )
    b.channel(n, "rotation", t, q, "VEC4")
    src = b.save(tmp_path / "roll.gltf")
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, src, "--out", out, "--json")
    assert code == 0, err
    report = json.loads(stdout)
    (w,) = report["warnings"]
    assert w["code"] == "swing" and w["channel"] == "head_yaw.rotation" and w["dofs"] == ["head_yaw"]
    assert w["swing_max_deg"] == pytest.approx(
        math.degrees(0.35 * math.sin(0.4 * math.pi)), abs=0.2
    )  # at t=0.2
    assert float(np.dot(w["suggested_axis"], [1, 0, 0])) > 0.95  # mostly the roll (some yaw too)
    assert "map it to 'head_roll'" in w["hint"] and '"axis": [' in w["hint"]
    m = report["mapped"][0]
    assert m["swing_max_deg"] == w["swing_max_deg"] and 0 < m["swing_rms_deg"] < m["swing_max_deg"]
    assert m["principal_share"] > 0.9
    # the threshold is an option; --strict fails only with warnings
    code, stdout, err = nutty(capsys, src, "--out", out, "--swing-warn", "30", "--strict")
    assert code == 0, err
    code, stdout, err = nutty(capsys, src, "--out", tmp_path / "no.json", "--strict")
    assert code == 1 and not (tmp_path / "no.json").exists()
    # the suggested axis in a mapping keeps the motion: no warning, the angle is the roll
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": {"head_yaw": {"dof": "head_roll", "axis": w["suggested_axis"]}}}))
    code, stdout, err = nutty(capsys, src, "--out", out, "--map", mp, "--json", "--tolerance", "0")
    assert code == 0, err
    assert json.loads(stdout)["warnings"] == []
    roll = [k["v"] for k in json.loads(out.read_text())["tracks"]["head_roll"]]
    assert max(roll) == pytest.approx(0.35, abs=0.02)


def test_limits_report_fit_and_nmf(tmp_path, capsys, desk):
    """A 1 Hz nod of 0.3 rad: peak velocity 1.88 rad/s (limit 1.5), acceleration 11.8 (5), jerk 74 (60).
    The slow-down that fits is the acceleration's sqrt(11.8 / 5) = 1.54; --fit-limits applies it."""
    mot = motion(240)
    t = np.arange(240) / RATE
    mot["Neck"][:, 2] = np.degrees(0.3 * np.sin(2 * np.pi * t))
    src = write_bvh(tmp_path / "nod.bvh", mot)
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": {"Neck": "neck_pitch"}}))
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(
        capsys, src, "--map", mp, "--forward", "z", "--out", out, "--json", "--tolerance", "0"
    )
    assert code == 0, err
    lim = json.loads(stdout)["limits"]
    row = lim["dofs"]["neck_pitch"]
    assert lim["rate"] == 100.0 and not lim["ok"] and row["samples"] == 200
    assert row["velocity"] > 0 and row["acceleration"] > 0 and row["jerk"] > 0
    assert row["max_velocity"] == pytest.approx(0.3 * 2 * math.pi, rel=0.02)
    assert row["max_acceleration"] == pytest.approx(0.3 * (2 * math.pi) ** 2, rel=0.05)
    assert row["velocity_limit"] == 1.5 and row["acceleration_limit"] == 5 and row["jerk_limit"] == 60
    assert lim["fit_scale"] == pytest.approx(math.sqrt(0.3 * (2 * math.pi) ** 2 / 5), rel=0.03)
    assert lim["nmf"]["best"] in "WABCDE" and lim["nmf"]["rms_deg"] > 0
    assert set(lim["nmf"]["presets"]) == set("WABCDE")
    # the human report says the same
    code, stdout, err = nutty(capsys, src, "--map", mp, "--forward", "z", "--out", out, "--tolerance", "0")
    assert "neck_pitch: velocity" in stdout and "to fit: play it 1.5" in stdout and "NMF preset" in stdout
    # --fit-limits slows it down and says so; the clip is then within the limits
    code, stdout, err = nutty(
        capsys, src, "--map", mp, "--forward", "z", "--out", out, "--json", "--fit-limits"
    )
    assert code == 0, err
    report = json.loads(stdout)
    s = report["limits"]["fit_applied"]
    assert s == pytest.approx(1.55, abs=0.06)
    assert report["limits"]["ok"] and report["limits"]["before"]["fit_scale"] == s
    assert any(n.startswith(f"--fit-limits: slowed down {s:.3g}x") for n in report["notes"])
    doc = json.loads(out.read_text())
    assert doc["duration"] == pytest.approx(239 / RATE * s, rel=1e-6)
    assert report["duration"] == pytest.approx(doc["duration"])
    again = analyse_clip(doc, desk, 100.0)
    assert again["ok"]


def test_within_limits_says_so(tmp_path, capsys):
    src = tmp_path / "slow.csv"
    src.write_text("time,head_yaw\n0,0\n2,0.2\n4,0\n")
    _code, stdout, _err = nutty(capsys, src, "--out", tmp_path / "c.json", "--json")
    lim = json.loads(stdout)["limits"]
    # linear keys: a corner at t = 2 s is a jump in velocity (acceleration over the limit at 100 Hz)
    assert lim["dofs"]["head_yaw"]["velocity"] == 0
    _code, stdout, _err = nutty(capsys, src, "--out", tmp_path / "c.json", "--interp", "bezier")
    assert "limits: every DoF is within its velocity, acceleration and jerk limits" in stdout


def test_trajectory_helpers():
    rate = 100.0
    t = np.arange(300) / rate
    x = np.stack([0.3 * np.sin(2 * np.pi * t), 0.01 * t], axis=1)
    counts = trajectory.limit_counts(x, rate, [1.5, 1.0], [5.0, 1.0], [60.0, 1.0])
    a = trajectory.analyze(x, rate, [1.5, 1.0], [5.0, 1.0], [60.0, 1.0])
    assert counts[1] == {
        "samples": 300,
        "velocity": 0,
        "max_velocity": pytest.approx(0.01),
        "velocity_limit": 1.0,
        "acceleration": 0,
        "max_acceleration": pytest.approx(0.0, abs=1e-9),
        "acceleration_limit": 1.0,
        "jerk": 0,
        "max_jerk": pytest.approx(0.0, abs=1e-6),
        "jerk_limit": 1.0,
    }
    # the same samples as analyze's classes (a sample over several limits counts in each here)
    over_any = (np.abs(a.velocity) > 1.5) | (np.abs(a.acceleration) > 5) | (np.abs(a.jerk) > 60)
    assert int(over_any[:, 0].sum()) == int((a.classes[:, 0] != 0).sum())
    assert counts[0]["velocity"] == int((np.abs(a.velocity[:, 0]) > 1.5).sum())

    def sample(times):
        return 0.3 * np.sin(2 * np.pi * np.asarray(times))[:, None]

    s = trajectory.time_scale_to_fit(sample, 3.0, rate, 1.5, 5.0, 60.0)
    assert s == pytest.approx(math.sqrt(0.3 * (2 * math.pi) ** 2 / 5), rel=0.02)
    assert trajectory.time_scale_to_fit(sample, 3.0, rate, 1.5, 5.0, 60.0, max_scale=1.2) is None
    assert trajectory.time_scale_to_fit(sample, 3.0, rate, 10, 100, 1000) == 1.0
    fits = trajectory.preset_fit(sample(t), rate, 1.5, 5.0, 60.0, pmin=-1, pmax=1)
    assert [f["preset"] for f in fits] and fits == sorted(fits, key=lambda f: f["rms"])
    assert all(f["rms"] > 0 for f in fits)


def test_hermite_keys_exact_at_kept_samples_and_within_tolerance(desk):
    t = np.arange(121) / 120
    v = 0.4 * np.sin(2 * np.pi * t) + 0.05 * np.sin(17 * t)
    keys = hermite_keys(t, v, 1e-3)
    assert 3 < len(keys) < 40 and all(k["interp"] == "bezier" and k["right_type"] == "free" for k in keys)
    doc = {"tracks": {"head_yaw": keys}, "duration": 1.0}
    got = sampler(doc, ["head_yaw"])(t)[:, 0]
    assert np.abs(got - v).max() <= 1e-3 + 1e-9
    kept = np.isin(t, [k["t"] for k in keys])
    np.testing.assert_allclose(got[kept], v[kept], atol=1e-9)
    # the sampler agrees with the engine's own curves
    from backend.engine.clips import compile_clip

    comp = compile_clip({"format": "nutty-clip/1", "name": "x", "tracks": {"head_yaw": keys}}, desk)
    out = np.zeros(desk.n_channels)
    for tt in (0.013, 0.37, 0.5, 0.81):
        comp.sample(tt, np.asarray(desk.rest), out)
        mine = sampler(doc, ["head_yaw"])(np.array([tt]))[0, 0]
        assert out[desk.dof("head_yaw").channels.start] == pytest.approx(mine, abs=1e-9)


def test_rotation_maths():
    rng = np.random.default_rng(5)
    # conversions: glTF/BVH +Y up -> robot +Z up
    c = quat_to_matrix(axis_conversion("y", "x"))
    np.testing.assert_allclose(c @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(c @ [0, 0, 1], [0, -1, 0], atol=1e-12)
    c = quat_to_matrix(axis_conversion("y", "z"))
    np.testing.assert_allclose(c @ [0, 0, 1], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(c @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(axis_conversion("z", "x")), np.eye(3), atol=1e-12)
    with pytest.raises(ValueError, match="perpendicular"):
        axis_conversion("y", "-y")
    # matrix <-> quaternion, and scale is removed
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        m = quat_to_matrix(q)
        back = quat_from_matrix(m * 2.5)
        assert abs(abs(float(back @ q)) - 1) < 1e-9
    # Davenport: angles about 3 chain axes in order, exact; with 2 axes the third is the leftover
    z, y, x = np.eye(3)[2], np.eye(3)[1], np.eye(3)[0]
    a = rng.uniform(-1.2, 1.2, size=(50, 3))
    q = quat_mul(
        quat_mul(quat_axis_angle(z, a[:, 0]), quat_axis_angle(y, a[:, 1])), quat_axis_angle(x, a[:, 2])
    )
    ang, left = davenport(q, [z, y, x])
    np.testing.assert_allclose(ang, a, atol=1e-9)
    assert left.max() < 1e-7
    ang2, left2 = davenport(q, [z, y])
    np.testing.assert_allclose(ang2, a[:, :2], atol=1e-9)
    np.testing.assert_allclose(left2, np.abs(a[:, 2]), atol=1e-7)
    tilted = quat_to_matrix(quat_axis_angle(x, -0.35)) @ z  # non-orthogonal axes (an ear's tilted axis)
    qt = quat_mul(quat_axis_angle(y, a[:, 0] * 0.5), quat_axis_angle(tilted, a[:, 1]))
    ang3, _ = davenport(qt, [y, tilted])
    np.testing.assert_allclose(ang3, np.stack([a[:, 0] * 0.5, a[:, 1]], axis=1), atol=1e-9)
    with pytest.raises(ValueError, match="parallel"):
        davenport(q, [z, -z])
    # principal axis
    axis = np.array([0.3, -0.2, 0.93])
    axis /= np.linalg.norm(axis)
    p, share = principal_axis(quat_axis_angle(axis, np.linspace(-0.5, 0.7, 30)))
    assert abs(float(p @ axis)) == pytest.approx(1.0, abs=1e-9) and share == pytest.approx(1.0)
    # slerp keeps unit length and ends
    q0, q1 = quat_axis_angle(z, 0.2), quat_axis_angle(x, 1.0)
    s = slerp(np.broadcast_to(q0, (3, 4)), np.broadcast_to(q1, (3, 4)), np.array([0.0, 0.5, 1.0]))
    np.testing.assert_allclose(np.linalg.norm(s, axis=1), 1.0)
    assert abs(float(s[0] @ q0)) == pytest.approx(1.0) and abs(float(s[2] @ q1)) == pytest.approx(1.0)


def test_symbolic_and_tilted_axes_use_the_robot_frame(desk):
    """Default axes are the URDF joints' axes in the robot's frame at rest (ear_right: -X)."""
    from backend.importers.mapping import dof_axis, robot_joint_frames

    np.testing.assert_allclose(dof_axis(desk, "ear_right"), [-1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(dof_axis(desk, "gaze_yaw"), [0, 0, 1], atol=1e-12)  # drives head_yaw most
    frames = robot_joint_frames(desk.urdf_path)
    ear = quat_to_matrix(frames["ear_left"]["world"])
    np.testing.assert_allclose(ear @ [0, 0, 1], [0, math.sin(0.35), math.cos(0.35)], atol=1e-12)
    assert urdf_axis("ear_left").tolist() == [1.0, 0.0, 0.0]


def test_import_clip_api_keeps_defaults(tmp_path, desk):
    """The Python API: analyse=False skips the trajectory-helper; the report still has swing and conversion."""
    b = GltfBuilder()
    n = b.node("head_yaw")
    b.channel(n, "rotation", [0.0, 1.0], qa(G([0, 0, 1]), [0.0, 0.5]), "VEC4")
    src = b.save(tmp_path / "a.gltf")
    doc, report = import_clip(src, desk, analyse=False)
    assert "limits" not in report and report["conversion"] == {"up": "y", "forward": "x"}
    assert report["mapped"][0]["swing_max_deg"] == pytest.approx(0.0, abs=1e-6)
    assert [k["v"] for k in doc["tracks"]["head_yaw"]] == pytest.approx([0.0, 0.5], abs=1e-7)
