"""`nutty serve --ros2` against real ROS 2 (rclpy from the wheels), in another process: what a ROS user
sees on /joint_states, /nutty/events and /nutty/status, and what gaze targets, commands and joint
trajectories sent over ROS do to the robot. Discovery stays on localhost and each test has its own
domain (tests/ros_env.py)."""

from __future__ import annotations

import json
import math
import os
import signal
import time

import numpy as np
import pytest

from backend.drivers.recorder import read_recording
from backend.engine.embodiment import load_embodiment
from tests.joint_truth import joint_truth
from tests.ros_env import ros_domain, ros_environ
from tests.server_process import server_process

pytest.importorskip("rclpy", reason="the [ros2] extra (make test installs it)")

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from tf2_msgs.msg import TFMessage
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from tests.ros_probe import RosProbe

pytestmark = [pytest.mark.server, pytest.mark.slow]
RATE = 100.0
STARTUP = 50  # messages at the start whose stamps the epoch may still be refined on (backend/ros2/view.py)


def _use_domain(patch: pytest.MonkeyPatch) -> int:
    """A ROS domain of its own, in this process's environment (inherited by the servers it starts)."""
    d = ros_domain()
    for key, value in ros_environ(d).items():
        if key.startswith(("ROS_", "RMW_")):
            patch.setenv(key, value)
    return d


@pytest.fixture
def domain(monkeypatch):
    """This test's ROS domain."""
    return _use_domain(monkeypatch)


@pytest.fixture(scope="module")
def _served_module():
    """One `nutty serve --ros2` and one probe for the tests that share them (a server per test would
    spend most of the module's time starting servers)."""
    with pytest.MonkeyPatch.context() as patch:
        probe = RosProbe(_use_domain(patch))
        probe.listen("/joint_states", JointState)
        probe.listen("/nutty/events", String)
        probe.listen("/nutty/status", String)
        probe.listen("/tf", TFMessage)
        try:
            with server_process("--no-previz", "--ros2", "--rate", str(RATE)) as server:
                yield server, probe
        finally:
            probe.close()


@pytest.fixture
def served(_served_module):
    """(server, probe): the shared server, idle, and a probe that has heard nothing yet."""
    server, probe = _served_module
    server.client.command("reset", fade=0.3)  # inputs, layers and actions as the program declares them
    time.sleep(1.0)  # the robot has blended back and the last test's events have arrived
    probe.clear()
    return server, probe


def _events(probe: RosProbe) -> list[dict]:
    return [json.loads(m.data) for m in list(probe.messages["/nutty/events"])]


def _wait_event(probe: RosProbe, fits, timeout: float = 20.0) -> dict:
    msg = probe.wait_for("/nutty/events", lambda m: fits(json.loads(m.data)), timeout)
    return json.loads(msg.data)


def _command(probe: RosProbe, doc: dict) -> None:
    pub = probe.publisher("/nutty/command", String)
    probe.wait_subscribers(pub)
    pub.publish(String(data=json.dumps(doc)))


def test_joint_states_are_the_joints_the_motors_get(served, tmp_path):
    _, probe = served
    emb = load_embodiment("nutty_desk")
    probe.wait_for("/joint_states", timeout=30)
    time.sleep(1.0)
    msgs = list(probe.messages["/joint_states"])
    assert len(msgs) >= 50
    assert list(msgs[-1].name) == list(emb.joint_names)
    stamps = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs])
    # stamped from the frames: one tick apart at the engine's rate, near the wall clock
    steps = np.diff(stamps)
    assert np.mean(np.isclose(steps, 1 / RATE, atol=1e-6)) > 0.9
    assert np.all(steps > 0)
    assert abs(stamps[-1] - time.time()) < 0.5  # the stamps follow the wall clock
    q = np.array([list(m.position) for m in msgs])
    truth = joint_truth("robots/nutty_desk")
    assert np.all(q >= truth.lower - 1e-12) and np.all(q <= truth.upper + 1e-12)
    # consecutive messages: velocities are the finite differences of the positions
    consecutive = np.isclose(steps, 1 / RATE, atol=1e-6)
    consecutive[:STARTUP] = False  # (see the trajectory test)
    qd = np.array([list(m.velocity) for m in msgs])
    fd = np.diff(q, axis=0) * RATE
    assert np.allclose(qd[1:][consecutive], fd[consecutive], atol=1e-9)


def test_joint_states_match_the_recorded_frames(domain, tmp_path):
    """The positions equal the joints composed from the frame's channels (tests/joint_truth.py, written
    from the robot's files), frame by frame, matched by their stamps."""
    out = tmp_path / "frames.jsonl"
    probe = RosProbe(domain)
    probe.listen("/joint_states", JointState)
    try:
        with server_process("--no-previz", "--ros2", "--record", str(out)) as server:
            server.client.play("nod")
            probe.wait_for("/joint_states", timeout=30)
            time.sleep(2.0)
    finally:
        probe.close()
    emb = load_embodiment("nutty_desk")
    truth = joint_truth("robots/nutty_desk")
    times, series, _ = read_recording(out)
    channels = np.tile(emb.rest, (len(times), 1))
    for name, values in series.items():
        channels[:, emb.channel_index[name]] = values
    recorded = truth.compose(emb, channels)
    msgs = list(probe.messages["/joint_states"])
    stamps = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs])
    q = np.array([list(m.position) for m in msgs])
    # The stamp says which frame a message is (to within a tick or two: the epoch is refined by
    # sub-millisecond steps as earlier-made frames are seen); its joints must be that frame's exactly.
    epoch = stamps[len(stamps) // 2] - times[np.argmin(np.abs(recorded - q[len(q) // 2]).sum(axis=1))]
    considered = matched = 0
    for s, row in zip(stamps, q, strict=True):
        k = round((s - epoch) * RATE)
        near = [j for j in range(k - 2, k + 3) if 0 <= j < len(times)]
        if len(near) < 5:
            continue  # before the recording started or after it ended
        considered += 1
        matched += any(np.allclose(row, recorded[j], atol=1e-9) for j in near)
        # whatever the stamps, every message is some recorded frame's joints, exactly
        assert np.any(np.all(np.abs(recorded - row) <= 1e-9, axis=1)), row
    # a clock that lost ticks under load moves the epoch up: a few messages then map further away
    assert considered > 100 and matched >= 0.9 * considered, (matched, considered)
    moving = np.ptp(q, axis=0)
    assert moving[emb.joint_names.index("head_pitch")] > 0.02  # the nod is in it


def test_the_base_moves_on_tf(served):
    server, probe = served
    first = probe.wait_for("/tf", timeout=30).transforms[0]
    assert (first.header.frame_id, first.child_frame_id) == ("odom", "base_link")
    for _ in range(40):  # a puppet stream (its layer fades out 0.5 s after the last message)
        server.client.command("puppet", values={"base_x": 0.2, "base_y": -0.1})
        time.sleep(0.1)

    def moved(m):
        t = m.transforms[0].transform.translation
        return abs(t.x - 0.2) < 1e-3 and abs(t.y + 0.1) < 1e-3

    # the base glides there within its limits, and /tf follows the frames
    t = probe.wait_for("/tf", moved, timeout=15).transforms[0]
    assert t.transform.rotation.w == pytest.approx(1.0) and t.transform.translation.z == 0.0
    stamp = t.header.stamp.sec + t.header.stamp.nanosec * 1e-9
    assert abs(stamp - time.time()) < 2.0


def test_status_and_command_events(served):
    server, probe = served
    status = json.loads(probe.wait_for("/nutty/status", timeout=30).data)
    assert status["rate"] == RATE and status["ros2"]["namespace"] == "/nutty"
    assert status["ros2"]["discovery_range"] == "LOCALHOST"
    _command(probe, {"type": "play_clip", "clip": "nod", "id": "ros-nod"})
    ack = _wait_event(probe, lambda e: e.get("type") == "ack" and e.get("id") == "ros-nod")
    assert ack["status"] in ("running", "started", "queued", "completed") or ack["status"]
    _wait_event(probe, lambda e: e.get("event") == "started" and e.get("id") == "ros-nod")
    _wait_event(probe, lambda e: e.get("event") == "completed" and e.get("id") == "ros-nod", timeout=30)
    # the same command log as REST
    assert server.client._call("GET", "/api/commands/ros-nod")["status"] == "completed"


def test_bad_commands_are_answered_and_change_nothing(served):
    server, probe = served
    probe.wait_for("/joint_states", timeout=30)
    _command(probe, {"type": "play_clip", "clip": "no_such_clip", "id": "bad-clip"})
    err = _wait_event(probe, lambda e: e.get("type") == "error" and e.get("id") == "bad-clip")
    assert "no_such_clip" in err["message"]
    rest = server.client._http.post("/api/commands", json={"type": "play_clip", "clip": "no_such_clip"})
    detail = rest.json()["detail"]
    # the same answer REST gives: status, code and field
    assert (err["status"], err["code"], err.get("field")) == (
        rest.status_code,
        detail["code"],
        detail.get("field"),
    )
    pub = probe.publisher("/nutty/command", String)
    pub.publish(String(data="{not json"))
    err = _wait_event(probe, lambda e: e.get("type") == "error" and e.get("code") == "malformed_json")
    assert err["status"] == 400
    assert server.client.status()["running"]


def test_gaze_target_sets_the_input(served):
    server, probe = served
    from geometry_msgs.msg import PointStamped  # lazy: after the module's skip

    pub = probe.publisher("/nutty/gaze_target", PointStamped)
    probe.wait_subscribers(pub)
    msg = PointStamped()
    msg.header.frame_id = "base_link"
    msg.point.x, msg.point.y, msg.point.z = 1.0, 0.4, 0.3
    pub.publish(msg)
    deadline = time.time() + 10
    while time.time() < deadline:
        value = server.client._call("GET", "/api/inputs")["values"].get("gaze_target")
        if value == pytest.approx([1.0, 0.4, 0.3]):
            break
        time.sleep(0.1)
    assert value == pytest.approx([1.0, 0.4, 0.3])
    # another frame: refused with a reason, the input unchanged
    msg.header.frame_id = "camera_link"
    msg.point.x = 2.0
    pub.publish(msg)
    err = _wait_event(probe, lambda e: e.get("type") == "error" and e.get("code") == "wrong_frame")
    assert err["source"] == "/nutty/gaze_target" and err["field"] == "header.frame_id"
    time.sleep(0.2)
    assert server.client._call("GET", "/api/inputs")["values"]["gaze_target"] == pytest.approx(
        [1.0, 0.4, 0.3]
    )


def _trajectory(joints, points, velocities=None):
    msg = JointTrajectory()
    msg.joint_names = list(joints)
    for k, (t, q) in enumerate(points):
        p = JointTrajectoryPoint()
        p.positions = [float(x) for x in q]
        if velocities is not None:
            p.velocities = [float(x) for x in velocities[k]]
        p.time_from_start.sec = int(t)
        p.time_from_start.nanosec = round((t - int(t)) * 1e9)
        msg.points.append(p)
    return msg


def test_joint_trajectory_drives_the_puppet_layer_within_limits(served):
    _, probe = served
    emb = load_embodiment("nutty_desk")
    yaw = emb.joint_names.index("head_yaw")
    pub = probe.publisher("/nutty/joint_trajectory", JointTrajectory)
    probe.wait_subscribers(pub)
    probe.wait_for("/joint_states", timeout=30)
    pub.publish(_trajectory(["head_yaw"], [(0.6, [0.5]), (1.2, [0.5])]))
    started = _wait_event(probe, lambda e: e.get("type") == "trajectory" and e.get("event") == "started")
    assert started["joints"] == ["head_yaw"] and started["points"] == 2
    _wait_event(probe, lambda e: e.get("type") == "trajectory" and e.get("event") == "completed", timeout=10)
    reached = probe.wait_for("/joint_states", lambda m: abs(m.position[yaw] - 0.5) < 0.02, timeout=5)
    assert reached is not None
    # after the hold the layer fades out: the program takes the head back
    time.sleep(2.5)
    assert abs(probe.messages["/joint_states"][-1].position[yaw] - 0.5) > 0.1
    msgs = list(probe.messages["/joint_states"])
    q = np.array([list(m.position) for m in msgs])
    stamps = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs])
    # after the first frames (whose stamps the epoch is still refined on), one tick apart by stamp is one
    # tick apart in the engine
    consecutive = np.isclose(np.diff(stamps), 1 / RATE, atol=1e-6)
    consecutive[:STARTUP] = False
    v = (np.diff(q, axis=0) * RATE)[consecutive]
    truth = joint_truth("robots/nutty_desk")
    assert np.all(np.abs(v) <= truth.velocity * (1 + 1e-9) + 1e-9)


def test_bad_trajectories_are_refused_by_field(served):
    _, probe = served
    pub = probe.publisher("/nutty/joint_trajectory", JointTrajectory)
    probe.wait_subscribers(pub)
    pub.publish(_trajectory(["no_joint"], [(0.5, [0.1])]))
    err = _wait_event(probe, lambda e: e.get("code") == "invalid_trajectory")
    assert err["field"] == "joint_names[0]" and "no_joint" in err["message"]
    pub.publish(_trajectory(["head_yaw"], [(0.5, [9.0])]))
    err = _wait_event(probe, lambda e: e.get("code") == "invalid_trajectory" and "outside" in e["message"])
    assert err["field"] == "points[0].positions[0]"
    pub.publish(_trajectory(["head_yaw"], [(0.5, [0.1]), (0.5, [0.2])]))
    _wait_event(probe, lambda e: e.get("code") == "invalid_trajectory" and "increasing" in e["message"])
    assert not any(e.get("type") == "trajectory" for e in _events(probe))


@pytest.mark.parametrize("controller", ["forward_position_controller", "joint_trajectory_controller"])
def test_ros2_control_outputs(domain, controller):
    probe = RosProbe(domain)
    js = probe.listen("/joint_states", JointState)
    topic, kind = (
        ("/forward_position_controller/commands", Float64MultiArray)
        if controller.startswith("forward")
        else ("/joint_trajectory_controller/joint_trajectory", JointTrajectory)
    )
    out = probe.listen(topic, kind)
    order = ["head_pitch", "head_yaw"]
    try:
        args = ("--no-previz", "--ros2", "--ros2-controller", controller, "--ros2-joints", ",".join(order))
        with server_process(*args) as server:
            probe.wait_for(topic, timeout=30)
            # after the probe hears the topic: on a busy machine discovery can outlast the shake
            server.client.play("shake")
            time.sleep(2.0)
    finally:
        probe.close()
    emb = load_embodiment("nutty_desk")
    cols = [emb.joint_names.index(j) for j in order]
    states = {tuple(np.round(np.array(m.position)[cols], 12)) for m in js}
    if kind is Float64MultiArray:
        values = [tuple(np.round(m.data, 12)) for m in out]
    else:
        assert all(list(m.joint_names) == order and len(m.points) == 1 for m in out)
        point = out[-1].points[0]
        assert point.time_from_start.sec == 0 and point.time_from_start.nanosec == 10_000_000
        assert len(point.velocities) == 2
        values = [tuple(np.round(m.points[0].positions, 12)) for m in out]
    assert len(values) > 100 and all(len(v) == 2 for v in values)
    # every command is the joint state of the same frame, in the configured order
    assert sum(v in states for v in values) >= 0.95 * min(len(values), len(js))
    assert np.ptp(np.array(values)[:, 1]) > 0.05  # the shake moves head_yaw


def test_token_needs_read_only_or_sros2(domain):
    import subprocess
    import sys

    from tests.server_process import free_port

    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "backend.cli",
            "serve",
            "--no-previz",
            "--port",
            str(free_port()),
            "--token",
            "t",
            "--ros2",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "ROS_SECURITY_ENABLE": ""},
    )
    assert proc.returncode == 2  # a usage error, as every other option conflict of `nutty serve`
    assert "--ros2-read-only" in proc.stderr and "SROS2" in proc.stderr


def test_read_only_subscribes_to_nothing_and_parks_on_sigterm(domain):
    probe = RosProbe(domain)
    probe.listen("/joint_states", JointState)
    emb = load_embodiment("nutty_desk")
    try:
        with server_process("--no-previz", "--ros2", "--ros2-read-only", "--token", "t") as server:
            probe.wait_for("/joint_states", timeout=30)
            pub = probe.publisher("/nutty/command", String)
            time.sleep(1.0)
            assert pub.get_subscription_count() == 0
            server.client._http.headers["Authorization"] = "Bearer t"
            server.client.play("nod")
            time.sleep(0.3)
            server.signal(signal.SIGTERM)
            assert server.wait_exit(30)
            time.sleep(0.5)
    finally:
        probe.close()
    last = np.array(probe.messages["/joint_states"][-1].position)
    rest = emb.joint_positions(emb.rest)
    assert np.allclose(last, rest, atol=1e-3), "the park's frames reach ROS before the link closes"
    assert math.isfinite(last.sum())
