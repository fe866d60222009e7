"""Forward kinematics of URDF chains: agrees with yourdfpy, Jacobians agree with finite differences."""

from __future__ import annotations

import numpy as np
import pytest
import yourdfpy

from backend.engine.kinematics import Chain, KinematicsError, chain_for, joint_depths, root_link

TIPS = ["head", "eye_left", "ear_right_link", "neck", "chest_led"]


@pytest.fixture(scope="module")
def scene_urdf(desk):
    return yourdfpy.URDF.load(str(desk.urdf_path), build_scene_graph=True, load_meshes=False)


@pytest.mark.parametrize("tip", TIPS)
def test_fk_matches_yourdfpy_on_random_configurations(desk, scene_urdf, tip):
    chain = Chain(desk, None, tip)
    rng = np.random.default_rng(42)
    names = scene_urdf.actuated_joint_names
    for _ in range(25):
        cfg = {n: rng.uniform(-1.0, 1.0) for n in names}
        scene_urdf.update_cfg(cfg)
        expected = scene_urdf.get_transform(tip, "base_link")
        q = np.array([cfg[n] for n in chain.joint_names])
        assert np.abs(chain.fk(q) - expected).max() < 1e-9
        _, tip_pose = chain.frames(q)
        assert np.abs(tip_pose - expected).max() < 1e-9


def test_fk_between_inner_links_matches_yourdfpy(desk, scene_urdf):
    chain = Chain(str(desk.urdf_path), "neck", "eye_right")
    assert chain.joint_names == ["head_yaw", "head_pitch", "head_roll"]
    rng = np.random.default_rng(1)
    for _ in range(10):
        q = rng.uniform(chain.lower, chain.upper)
        scene_urdf.update_cfg(dict(zip(chain.joint_names, q)))
        assert np.abs(chain.fk(q) - scene_urdf.get_transform("eye_right", "neck")).max() < 1e-9


def test_chain_structure_and_channel_map(desk):
    chain = chain_for(desk, None, "head")
    assert chain is chain_for(desk, None, "head")  # cached
    assert root_link(desk) == "base_link"
    assert chain.joint_names == ["body_yaw", "neck_pitch", "head_yaw", "head_pitch", "head_roll"]
    assert [desk.channel_names[c] for c in chain.dof_channels] == chain.joint_names
    values = desk.rest.copy()
    values[desk.channel_index["gaze_yaw"]] = 0.5  # symbolic: body 0.3, head 0.7
    q = chain.q_from_channels(values)
    assert q[0] == pytest.approx(0.15) and q[2] == pytest.approx(0.35)
    depths = joint_depths(desk)
    assert depths["head_yaw"] > depths["body_yaw"] and depths["head_pitch"] > depths["neck_pitch"]


def test_bad_chains_are_clear_errors(desk):
    with pytest.raises(KinematicsError, match="no link 'nose'"):
        Chain(desk, None, "nose")
    with pytest.raises(KinematicsError, match="not below"):
        Chain(desk, "head", "torso")


@pytest.mark.parametrize("tip", ["head", "ear_left_link"])
def test_jacobians_match_finite_differences(desk, tip):
    chain = Chain(desk, None, tip)
    rng = np.random.default_rng(7)
    point = np.array([0.075, 0.01, 0.085])
    direction = np.array([1.0, 0.0, 0.0])
    eps = 1e-6
    for _ in range(5):
        q = rng.uniform(chain.lower, chain.upper)
        j = chain.jacobian(q, point)
        _, _p, d, jp, jd = chain.kinematics(q, point, direction)
        assert np.allclose(j[:3], jp)
        for i in range(chain.n):
            dq = np.zeros(chain.n)
            dq[i] = eps
            t_plus, t_minus = chain.fk(q + dq), chain.fk(q - dq)
            p_plus = t_plus[:3, :3] @ point + t_plus[:3, 3]
            p_minus = t_minus[:3, :3] @ point + t_minus[:3, 3]
            assert np.allclose((p_plus - p_minus) / (2 * eps), jp[:, i], atol=1e-7)
            assert np.allclose((t_plus[:3, 0] - t_minus[:3, 0]) / (2 * eps), jd[:, i], atol=1e-7)
            # angular velocity: dR/dq = [w]x R
            d_r = (t_plus[:3, :3] - t_minus[:3, :3]) / (2 * eps)
            w_skew = d_r @ chain.fk(q)[:3, :3].T
            w = np.array([w_skew[2, 1], w_skew[0, 2], w_skew[1, 0]])
            assert np.allclose(w, j[3:, i], atol=1e-7)
        d_dir, jd2 = chain.direction_jacobian(q)
        assert np.allclose(d_dir, d) and np.allclose(jd2, jd)


def test_prismatic_and_mimic_joints(tmp_path):
    urdf = tmp_path / "slide.urdf"
    urdf.write_text("""<?xml version="1.0"?>
<robot name="slide">
  <link name="a"/><link name="b"/><link name="c"/><link name="d"/>
  <joint name="lift" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1" rpy="0.1 0.2 0.3"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="0.3" velocity="1" effort="1"/></joint>
  <joint name="turn" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 1 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="follow" type="revolute"><parent link="c"/><child link="d"/><origin xyz="0.1 0.05 0"/>
    <axis xyz="1 0 0"/><limit lower="-2" upper="2" velocity="1" effort="1"/>
    <mimic joint="turn" multiplier="-0.5" offset="0.2"/></joint>
</robot>""")
    chain = Chain(str(urdf), None, "d")
    assert chain.joint_names == ["lift", "turn"]
    ref = yourdfpy.URDF.load(str(urdf), build_scene_graph=True, load_meshes=False)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = np.array([rng.uniform(0, 0.3), rng.uniform(-1, 1)])
        ref.update_cfg({"lift": q[0], "turn": q[1]})
        assert np.abs(chain.fk(q) - ref.get_transform("d", "a")).max() < 1e-9
        j = chain.jacobian(q)
        for i in range(2):
            dq = np.zeros(2)
            dq[i] = 1e-6
            fd = (chain.fk(q + dq)[:3, 3] - chain.fk(q - dq)[:3, 3]) / 2e-6
            assert np.allclose(fd, j[:3, i], atol=1e-7)
