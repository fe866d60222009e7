"""What robotics tools see of a frame (backend/ros2/view.py), checked against independent arithmetic:
stamps, the base's pose as a quaternion, the joint velocities, and stamps that follow the wall clock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from backend.ros2.view import DRIFT, FrameView, Stamp, quaternion_from_euler
from backend.session import EngineSession


def _rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    cz, sz, cy, sy, cx, sx = (
        math.cos(yaw),
        math.sin(yaw),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(roll),
        math.sin(roll),
    )
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    return rz @ ry @ rx


def _matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


@pytest.mark.parametrize("angles", [(0.3, 0.0, 0.0), (0.4, -0.2, 0.1), (-2.0, 0.7, -1.2)])
def test_quaternion_is_the_zyx_rotation(angles):
    q = quaternion_from_euler(*angles)
    assert math.isclose(sum(c * c for c in q), 1.0)
    assert np.allclose(_matrix(q), _rotation(*angles), atol=1e-12)


def test_stamp_splits_seconds():
    s = Stamp.of(1_795_000_000.25)
    assert (s.sec, s.nanosec) == (1_795_000_000, 250_000_000)
    assert Stamp.of(2.0 - 1e-10).nanosec < 1_000_000_000


def test_joints_base_and_wall_clock(desk):
    session = EngineSession.create(desk, rate=100.0)
    session.load_program(open("robots/nutty_desk/programs/interactive.json").read())
    frames = [session.engine.tick() for _ in range(60)]
    view = FrameView(desk)
    q0, _ = view.joints(frames[0])
    q1, qd1 = view.joints(frames[1])
    assert np.allclose(qd1, (q1 - q0) * 100.0)  # consecutive: the finite difference
    assert np.array_equal(q1, frames[1].joint_values(desk))
    base = view.base(frames[1])
    assert base is not None and (base.parent, base.child) == ("odom", "base_link")
    x = frames[1].position[desk.channel_index["base_x"]]
    assert base.translation[0] == x
    # made 3 ms, then 1 ms after their time: the epoch takes the earliest; a clock 50 ms behind moves it up
    view.follow_wall(frames[2], 1000.0 + frames[2].t + 0.003)
    view.follow_wall(frames[3], 1000.0 + frames[3].t + 0.001)
    assert view.epoch == pytest.approx(1000.001)
    view.follow_wall(frames[4], 1000.0 + frames[4].t + 0.004)
    assert view.epoch == pytest.approx(1000.001)
    view.follow_wall(frames[5], 1000.0 + frames[5].t + DRIFT + 0.03)
    assert view.epoch == pytest.approx(1000.0 + DRIFT + 0.03)
