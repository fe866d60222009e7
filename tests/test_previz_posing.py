"""The clip editor's preview in the viser Pre-Viz: a leased preview pose takes the solid robot (the ghost
shows the live robot), and a link clicked in the preview turns its joint's DoF about the joint's axis."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from server_process import free_port

from backend.graph.builder import ProgramBuilder
from backend.pose_preview import PosePreview
from backend.previz_posing import turn_about_x
from backend.session import EngineSession

CLIENT = 7  # a viser client id the tests mark as trusted


@pytest.fixture()
def previz(desk):
    from backend.previz import PreViz

    b = ProgramBuilder("still")
    b.chain(b.node("rest_pose", "rest"), b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    pv = PreViz(session, port=free_port())
    pv._trusted.add(CLIENT)
    yield pv
    pv.stop()
    session.engine.close()


def quat_about(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return np.array([math.cos(angle / 2), *(axis * math.sin(angle / 2))])


def quat_mul(a, b):
    from backend.previz_posing import _quat_mul

    return _quat_mul(a, b)


def rotation(q):
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_turn_about_x_reads_back_the_angle_from_any_start():
    q0 = quat_about([0.3, -1.0, 0.5], 1.1)
    for angle in (-3.0, -0.4, 0.0, 0.25, 2.9):
        assert turn_about_x(q0, quat_mul(q0, quat_about([1, 0, 0], angle))) == pytest.approx(angle, abs=1e-9)


def test_a_preview_takes_the_solid_robot_and_the_ghost_shows_the_live_one(previz, desk):
    frame = previz.session.engine.tick()
    yaw = desk.channel_index["head_yaw"]
    pose = desk.rest.copy()
    pose[yaw] = 0.6
    previz.set_preview(pose, "nod @ 0.40 s", 0.3)
    previz.show(frame)
    assert previz.shown()["joints"]["head_yaw"] == pytest.approx(0.6)
    assert "nod @ 0.40 s" in previz.posing.label.text and "not moved" in previz.posing.label.text
    time.sleep(0.35)  # the lease lapses: the live robot again, and the label goes
    previz.show(frame)
    assert previz.shown()["joints"]["head_yaw"] == pytest.approx(
        frame.joints[desk.joint_names.index("head_yaw")]
    )
    assert previz.posing.label.text == ""


def test_clicking_a_link_puts_a_ring_on_its_joint_axis_and_turning_it_sets_the_dof(previz, desk):
    preview = PosePreview(desk, previz)
    previz.on_pose_grab = preview.grab
    assert previz.posing.click("neck", CLIENT) is None  # no preview shows: clicks do nothing
    preview.show({"body_yaw": 0.5, "neck_pitch": 0.1}, "pose")
    assert previz.posing.click("neck", None) is None  # a click nobody vouches for
    assert previz.posing.click("neck", CLIENT) == "neck_pitch"
    assert preview.state()["grabbed"] == {"neck_pitch": pytest.approx(0.1)}
    ring = previz.posing._ring
    # the ring's x axis is the neck's pitch axis (y) turned by the body's yaw
    assert rotation(ring.wxyz)[:, 0] == pytest.approx([-math.sin(0.5), math.cos(0.5), 0.0], abs=1e-6)
    turned = quat_mul(np.asarray(ring.wxyz), quat_about([1, 0, 0], 0.2))
    assert previz.posing.turn(turned, CLIENT) == pytest.approx(0.3)
    assert previz.posing.turn(turned, 99) is None  # an untrusted client's turn
    state = preview.state()  # the click marked the DoF (at its value then), the turn set it
    assert state["grabbed"] == {"neck_pitch": pytest.approx(0.3)} and state["revision"] == 2
    frame = previz.session.engine.tick()
    previz.show(frame)
    assert previz.shown()["joints"]["neck_pitch"] == pytest.approx(0.3)  # the turn shows at once
    far = quat_mul(np.asarray(ring.wxyz), quat_about([1, 0, 0], 3.0))
    assert previz.posing.turn(far, CLIENT) == pytest.approx(desk.dof("neck_pitch").max)  # clamped


def test_a_link_under_a_symbolic_only_joint_turns_the_joint_s_own_dof(previz, desk):
    previz.set_preview(desk.rest.copy(), "x", 5.0)
    assert previz.posing.click("ear_left_link", CLIENT) == "ear_left"
    assert previz.posing.click("eye_left", CLIENT) == "head_roll"  # fixed to the head: its joint
    assert previz.posing.click("base_link", CLIENT) is None  # the base moves with no joint
