"""Embodiment loading: kinematronics dimensions, limits, symbolic DoFs, bare URDFs, errors."""

from __future__ import annotations

import json
import math
import textwrap

import numpy as np
import pytest

from backend.cli import main
from backend.engine.embodiment import (
    ACC_PER_VEL,
    JERK_PER_ACC,
    ChannelKind,
    EmbodimentError,
    load_embodiment,
)

TWO_JOINT_URDF = """<?xml version="1.0"?>
<robot name="arm2">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="tip"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1.0" upper="1.5" velocity="2.0" effort="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2.0" upper="2.0" velocity="3.0" effort="1"/></joint>
  <joint name="finger_mimic" type="revolute"><parent link="l2"/><child link="l3"/><axis xyz="0 1 0"/>
    <limit lower="-2.0" upper="2.0" velocity="3.0" effort="1"/><mimic joint="elbow" multiplier="0.5"/></joint>
  <joint name="wrist_fixed" type="fixed"><parent link="l3"/><child link="tip"/></joint>
</robot>
"""


@pytest.fixture()
def arm_urdf(tmp_path):
    p = tmp_path / "arm2.urdf"
    p.write_text(TWO_JOINT_URDF)
    return p


def test_default_robot_has_all_four_dimensions(desk):
    counts = desk.dimension_counts()
    assert counts == {"stationary": 12, "spatial": 2, "display": 4, "audible": 2}
    # one channel per continuous/enum DoF, three per colour DoF, none per event DoF
    assert desk.n_channels == 12 + 2 + 3 + 3 + 1 + 1
    assert desk.channel_kind[desk.channel_index["eye_leds.g"]] == ChannelKind.colour
    assert desk.channel_kind[desk.channel_index["mouth"]] == ChannelKind.enum
    assert desk.dof("speech").channels.start == desk.dof("speech").channels.stop


def test_default_robot_limits_come_from_urdf_and_yaml(desk):
    head_yaw = desk.dof("head_yaw")
    assert (head_yaw.min, head_yaw.max, head_yaw.velocity) == (-1.2, 1.2, 2.5)  # URDF
    assert head_yaw.acceleration == 10 and head_yaw.jerk == 120  # embodiment.yaml
    assert desk.dof("eyelid_left").rest == 0.15
    assert np.all(desk.rest >= desk.min) and np.all(desk.rest <= desk.max)


def test_symbolic_dof_drives_joints_with_coefficients(desk):
    values = desk.rest.copy()
    values[desk.channel_index["gaze_pitch"]] = 0.3
    q = dict(zip(desk.joint_names, desk.joint_positions(values)))
    assert q["neck_pitch"] == pytest.approx(0.6 * 0.3)
    assert q["head_pitch"] == pytest.approx(0.4 * 0.3)
    # a real DoF and a symbolic one on the same joint add up
    values[desk.channel_index["neck_pitch"]] = 0.1
    q = dict(zip(desk.joint_names, desk.joint_positions(values)))
    assert q["neck_pitch"] == pytest.approx(0.1 + 0.18)


def test_joint_positions_at_rest_match_rest_pose(desk):
    q = dict(zip(desk.joint_names, desk.joint_positions(desk.rest)))
    assert q["eyelid_left"] == pytest.approx(0.15)
    assert q["head_yaw"] == 0.0


def test_spatial_group_is_coupled(desk):
    assert [desk.channel_names[i] for i in desk.groups["base_planar"]] == ["base_x", "base_y"]
    values = desk.rest.copy()
    values[desk.channel_index["base_x"]] = 0.2
    assert desk.base_pose(values)["x"] == pytest.approx(0.2)


def test_bare_urdf_uses_actuated_joints_with_documented_defaults(arm_urdf):
    emb = load_embodiment(arm_urdf)
    assert emb.dof_names == ["shoulder", "elbow"]  # fixed and mimic joints are not DoFs
    sh = emb.dof("shoulder")
    assert (sh.min, sh.max, sh.velocity) == (-1.0, 1.5, 2.0)
    assert sh.acceleration == pytest.approx(ACC_PER_VEL * 2.0)
    assert sh.jerk == pytest.approx(JERK_PER_ACC * ACC_PER_VEL * 2.0)
    assert emb.dimension_counts() == {"stationary": 2, "spatial": 0, "display": 0, "audible": 0}


def _robot_folder(tmp_path, yaml_text):
    folder = tmp_path / "bot"
    folder.mkdir()
    (folder / "robot.urdf").write_text(TWO_JOINT_URDF)
    (folder / "embodiment.yaml").write_text(textwrap.dedent(yaml_text))
    return folder


@pytest.mark.parametrize(
    "yaml_text, fragment",
    [
        ("name: b\nstationary: [{name: knee}]\n", "no actuated joint 'knee'"),
        ("name: b\nstationary: [{name: finger_mimic}]\n", "mimic joint"),
        ("name: b\nstationary: [{name: elbow}, {name: elbow}]\n", "declared twice"),
        ("name: b\nstationary: [{name: elbow, rest: 5}]\n", "rest 5"),
        ("name: b\ndisplay: [{name: face, type: enum}]\n", "needs a non-empty 'options'"),
        ("name: b\nstationary: [{name: elbow, velocity: -1}]\n", "velocity"),
        ("name: b\nspatial: [{name: a, axis: x}, {name: b2, axis: x}]\n", "axis 'x' is already declared"),
        ("name: b\nstationary: [{name: g, drives: {nope: 1.0}}]\n", "unknown actuated joint 'nope'"),
        ("name: b\npostures: {p: {ghost: 1}}\n", "unknown DoF 'ghost'"),
        ("name: b\nstationary: [{name: elbow, colour: red}]\n", "colour"),
        ("name: b\npostures: {p: {values: {ghost: 1}}}\n", "unknown DoF 'ghost'"),
        (
            "name: b\npostures: {p: {description: up, values: {elbow: 1}, elbow: 1}}\n",
            "only 'description' and 'values'",
        ),
    ],
)
def test_bad_embodiment_yaml_is_explained(tmp_path, yaml_text, fragment):
    with pytest.raises(EmbodimentError) as err:
        load_embodiment(_robot_folder(tmp_path, yaml_text))
    assert fragment in str(err.value)


def test_postures_load_in_both_shapes_with_their_descriptions(tmp_path, desk):
    yaml_text = (
        "name: b\nstationary: [{name: elbow}, {name: shoulder}]\npostures:\n"
        "  flat: {elbow: 0.5}\n  described: {description: Arm up., values: {elbow: 1.0, shoulder: 0.2}}\n"
    )
    emb = load_embodiment(_robot_folder(tmp_path, yaml_text))
    assert emb.postures == {"flat": {"elbow": 0.5}, "described": {"elbow": 1.0, "shoulder": 0.2}}
    assert emb.posture_descriptions == {"flat": "", "described": "Arm up."}
    assert all(
        desk.posture_descriptions[name] for name in desk.postures
    )  # every bundled posture is described


def test_symbolic_range_follows_its_joints(tmp_path):
    emb = load_embodiment(
        _robot_folder(tmp_path, "name: b\nstationary: [{name: both, drives: {shoulder: 0.5, elbow: 1.0}}]\n")
    )
    d = emb.dof("both")
    # shoulder allows [-1, 1.5] / 0.5 = [-2, 3]; elbow [-2, 2] -> intersection [-2, 2]
    assert (d.min, d.max) == (-2.0, 2.0)
    assert d.velocity == pytest.approx(min(2.0 / 0.5, 3.0 / 1.0))


def test_missing_robot_is_a_clear_error():
    with pytest.raises(EmbodimentError, match="no robot at"):
        load_embodiment("/definitely/not/here")


def test_cli_embodiment_table(capsys):
    assert main(["embodiment", "nutty_desk"]) == 0
    out = capsys.readouterr().out
    assert "stationary 12" in out and "audible 2" in out
    assert "gaze_pitch" in out and "drives neck_pitch×0.6, head_pitch×0.4" in out


def test_cli_embodiment_json(capsys, arm_urdf):
    assert main(["embodiment", str(arm_urdf), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["name"] == "arm2"
    assert doc["dimensions"] == {"stationary": 2, "spatial": 0, "display": 0, "audible": 0}
    first = doc["dofs"][0]
    for key in ("name", "dimension", "type", "min", "max", "velocity", "acceleration", "jerk", "rest"):
        assert key in first
    assert first["velocity"] == 2.0 and math.isclose(first["acceleration"], 8.0)


def test_cli_embodiment_bad_robot_exit_code(capsys):
    assert main(["embodiment", "/nope"]) == 2
    assert "no robot at" in capsys.readouterr().err


def _example_robot_data():
    import glob
    import site

    roots = [
        p
        for s in site.getsitepackages()
        for p in glob.glob(f"{s}/cmeel.prefix/share/example-robot-data/robots")
    ]
    if not roots:
        pytest.skip("example-robot-data is not installed (optional extra `robots`, ~440 MB)")
    return roots[0]


def test_third_party_panda_urdf_loads_with_mimic_finger():
    """Real third-party robots from the `example-robot-data` package (optional extra)."""
    emb = load_embodiment(f"{_example_robot_data()}/panda_description/urdf/panda.urdf")
    assert len(emb.dofs) == 8  # 7 arm joints + one finger; panda_finger_joint2 mimics joint1
    assert "panda_finger_joint2" not in emb.dof_names
    assert emb.dof("panda_joint4").max < 0  # a joint whose range excludes 0: rest clamps into range
    assert emb.dof("panda_joint4").rest == emb.dof("panda_joint4").max
    assert np.all(emb.min < emb.max)


@pytest.mark.parametrize(
    "rel", ["ur_description/urdf/ur5_robot.urdf", "talos_data/robots/talos_reduced.urdf"]
)
def test_third_party_urdfs_load(rel):
    emb = load_embodiment(f"{_example_robot_data()}/{rel}")
    assert emb.dimension_counts()["stationary"] >= 6
    assert np.all(np.isfinite(emb.vel_limit)) and np.all(emb.vel_limit > 0)
    np.testing.assert_allclose(
        emb.joint_positions(emb.rest)[: len(emb.dofs)], emb.rest[: len(emb.joints)][: len(emb.dofs)]
    )
