"""`nutty play`: a recording replayed (a real subprocess) into `--record out.jsonl` through the safety net:
from rest to the first pose and back to rest within the robot's limits (checked with the independent
limits of tests/joint_truth.py and the robot's own yaml), the recorded frames exactly in between, and
clear errors for inputs it cannot play."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml

from backend.cli import main
from backend.commands.serve import builtin_idle
from backend.drivers import FrameRecorder
from backend.engine.frames import FrameEvent
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession
from tests.joint_truth import ROBOTS, TEST_ROBOTS, joint_truth
from tests.server_process import stop_process

pytest.importorskip("mcap")
pytest.importorskip("rosbags")

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer as Ros2Writer

from backend.recording.mcap_recorder import McapRecorder

RATE = 100
WARM, TICKS = 60, 100  # ticks before recording (the first pose is away from rest), ticks recorded
DESK = ROBOTS / "nutty_desk"


def wave_program():
    b = ProgramBuilder("wave")
    wave = b.node("sine", "wave", dofs=["head_yaw", "body_yaw", "base_x"], amplitude=0.12, frequency=0.3)
    b.chain(wave, b.output())
    return b.build()


def record(desk, path, sink_cls):
    """A headless take into `path` (1 s, after WARM ticks), with one spoken line: the frames."""
    session = EngineSession.create(desk, rate=RATE, program=wave_program())
    list(session.run_headless(WARM))
    session.engine.add_sink(sink_cls(desk, path))
    frames = list(session.run_headless(TICKS // 2))
    session.engine.inject_event(FrameEvent("speech", "say", {"text": "again"}))
    frames += list(session.run_headless(TICKS - TICKS // 2))
    session.engine.close()
    return frames


@pytest.fixture(scope="module")
def take(desk, tmp_path_factory):
    path = tmp_path_factory.mktemp("play") / "take.mcap"
    return path, record(desk, path, McapRecorder)


def play(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "backend.cli", "play", *args, "--sim-servo", "0"],
        capture_output=True,
        text=True,
        timeout=timeout,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def summary_of(stdout: str) -> dict:
    line = next(x for x in stdout.splitlines() if x.startswith("nutty play: summary "))
    return json.loads(line.removeprefix("nutty play: summary "))


def replayed(path):
    """(joints (T, J), base_x (T,), dt, events per frame) of a JSON-lines recording of the replay."""
    docs = [json.loads(x) for x in path.read_text().splitlines()]
    joints = np.array([list(d["joints"].values()) for d in docs])
    base = np.array([d["dofs"]["base_x"]["position"] for d in docs])
    return joints, base, docs[0]["dt"], [d["events"] for d in docs]


def assert_safe(desk, joints, base, rate):
    """From rest (the robot is assumed there before the first frame) to rest, within the limits."""
    truth = joint_truth(DESK)
    rest = np.tile(desk.joint_positions(desk.rest), (3, 1))
    q = np.vstack([rest, joints])
    truth.assert_within(q, rate, "replay from rest")
    np.testing.assert_array_equal(joints[-1], rest[0])  # parked exactly at rest
    spatial = {e["name"]: e for e in yaml.safe_load((DESK / "embodiment.yaml").read_text())["spatial"]}
    x = np.concatenate([[0.0, 0.0, 0.0], base])
    v = np.diff(x) * rate
    assert np.abs(v).max() <= spatial["base_x"]["velocity"] * (1 + 1e-9)
    assert np.abs(np.diff(v) * rate).max() <= spatial["base_x"]["acceleration"] * (1 + 1e-9)
    assert base[-1] == 0.0


def test_play_an_mcap_into_a_recording(desk, take, tmp_path):
    path, frames = take
    out = tmp_path / "out.jsonl"
    started = time.monotonic()
    res = play(str(path), "--robot", "nutty_desk", "--record", str(out))
    assert res.returncode == 0, res.stderr
    s = summary_of(res.stdout)
    assert s["frames"] == TICKS and s["corrected"] == 0 and s["parked"] and not s["stopped"]
    assert s["lead_in_ticks"] > 10 and s["park_ticks"] > 10  # the first pose is well away from rest
    joints, base, dt, events = replayed(out)
    assert dt == pytest.approx(1 / RATE) and len(joints) == s["lead_in_ticks"] + TICKS + s["park_ticks"]
    # real time: the whole replay took at least its own length
    assert time.monotonic() - started >= len(joints) / RATE
    lead = s["lead_in_ticks"]
    np.testing.assert_array_equal(
        joints[lead : lead + TICKS], np.array([f.joint_values(desk) for f in frames])
    )
    said = [k - lead for k, e in enumerate(events) if e]
    assert said == [k for k, f in enumerate(frames) if f.events]
    assert events[lead + said[0]][0]["payload"]["text"] == "again"
    assert_safe(desk, joints, base, RATE)


def test_play_a_jsonl_recording_twice_as_fast_stays_within_the_limits(desk, tmp_path):
    src = tmp_path / "take.jsonl"
    frames = record(desk, src, FrameRecorder)
    out = tmp_path / "out.jsonl"
    res = play(str(src), "--robot", "nutty_desk", "--speed", "2", "--record", str(out))
    assert res.returncode == 0, res.stderr
    s = summary_of(res.stdout)
    joints, base, dt, _events = replayed(out)
    assert dt == pytest.approx(0.5 / RATE)
    # at twice the speed the base would go faster than it may: the net corrects it, the rest is exact
    assert s["frames"] == TICKS and s["corrected"] > 0
    lead = s["lead_in_ticks"]
    head = desk.joint_names.index("head_yaw")
    played = joints[lead : lead + TICKS, head]
    recorded = np.array([f.joint_values(desk)[head] for f in frames])
    assert np.abs(played - recorded).max() < 0.05  # tracked closely, within the limits at 200 Hz
    assert_safe(desk, joints, base, 2 * RATE)


JOINT_STATE_DEF = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def test_play_a_foreign_bag_of_joint_states(desk, tmp_path):
    """A bag written by another tool (mcap_ros2's writer) with joints of which only some are the robot's."""
    bag = tmp_path / "foreign.mcap"
    names = ["head_yaw", "wheel_left", "body_yaw"]
    t = np.arange(50) / 50.0  # 50 Hz
    with bag.open("wb") as fh:
        writer = Ros2Writer(fh)
        schema = writer.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE_DEF)
        for k, tk in enumerate(t):
            ns = 1_700_000_000_000_000_000 + round(tk * 1e9)
            stamp = {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}
            msg = {
                "header": {"stamp": stamp, "frame_id": ""},
                "name": names,
                "position": [0.2 + 0.1 * tk, 3.0, -0.1],
                "velocity": [],
                "effort": [],
            }
            writer.write_message("/joint_states", schema, msg, log_time=ns, publish_time=ns, sequence=k)
        writer.finish()
    out = tmp_path / "out.jsonl"
    res = play(str(bag), "--robot", "nutty_desk", "--record", str(out))
    assert res.returncode == 0, res.stderr
    assert "not played: wheel_left" in res.stdout
    s = summary_of(res.stdout)
    joints, base, dt, _ = replayed(out)
    assert dt == pytest.approx(1 / 50) and s["frames"] == 50
    lead = s["lead_in_ticks"]
    head, body = desk.joint_names.index("head_yaw"), desk.joint_names.index("body_yaw")
    np.testing.assert_allclose(joints[lead : lead + 50, head], 0.2 + 0.1 * t, atol=1e-12)
    np.testing.assert_allclose(joints[lead : lead + 50, body], -0.1, atol=1e-12)
    assert_safe(desk, joints, base, 50)


def test_a_signal_parks_the_robot_within_its_limits(desk, take, tmp_path):
    path, _frames = take
    out = tmp_path / "out.jsonl"
    args = [str(path), "--robot", "nutty_desk", "--loop", "--record", str(out), "--sim-servo", "0"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "backend.cli", "play", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        deadline = time.monotonic() + 40
        while time.monotonic() < deadline and (not out.exists() or out.read_text().count("\n") < 450):
            time.sleep(0.2)  # into the second loop (the first: a lead-in under 2 s and 1 s of frames)
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        stop_process(proc)
    assert proc.returncode == 0, stderr
    s = summary_of(stdout)
    assert s["stopped"] and s["parked"] and s["loops"] >= 1 and s["park_ticks"] > 0
    joints, base, _dt, _ = replayed(out)
    assert_safe(desk, joints, base, RATE)


def run_cli(*argv: str) -> int:
    return main(["play", *argv])


@pytest.mark.parametrize(
    ("argv", "code", "message"),
    [
        (["{tmp}/missing.mcap"], 2, "no recording at"),
        (["{tmp}/take.csv"], 2, "FILE.mcap or FILE.jsonl"),
        (["{tmp}/garbage.mcap"], 1, "not a readable MCAP recording"),
        (["{tmp}/empty.jsonl"], 1, "holds no frames"),
        (["{take}", "--speed", "0"], 2, "--speed must be within"),
        (["{take}", "--robot", "no_such_robot"], 2, "no_such_robot"),
        (["{other}"], 1, "channels differ from robot 'nutty_desk'"),
        (["{renamed}"], 1, "the recording lacks head_yaw; the robot has no head_yew"),
    ],
)
def test_bad_inputs_give_clear_errors(desk, take, tmp_path, capsys, argv, code, message):
    from backend.engine.embodiment import load_embodiment

    (tmp_path / "take.csv").write_text("t\n0\n")
    (tmp_path / "garbage.mcap").write_bytes(b"not an mcap file at all")
    (tmp_path / "empty.jsonl").write_text("\n")
    other = tmp_path / "other.mcap"
    if "{other}" in argv:  # a take of another robot
        arm = load_embodiment(str(TEST_ROBOTS / "pan_tilt_eyes"))
        rec = McapRecorder(arm, other)
        session = EngineSession.create(arm, rate=RATE, program=builtin_idle(arm.name))
        session.engine.add_sink(rec)
        list(session.run_headless(5))
        session.engine.close()
    renamed = tmp_path / "renamed.jsonl"
    if "{renamed}" in argv:  # a JSON-lines take whose DoF was renamed
        record(desk, renamed, FrameRecorder)
        renamed.write_text(renamed.read_text().replace('"head_yaw": {', '"head_yew": {'))
    values = {
        "{tmp}": str(tmp_path),
        "{take}": str(take[0]),
        "{other}": str(other),
        "{renamed}": str(renamed),
    }
    args = [next((a.replace(k, v) for k, v in values.items() if k in a), a) for a in argv]
    if "--robot" not in args:
        args += ["--robot", "nutty_desk"]
    assert run_cli(*args) == code
    assert message in capsys.readouterr().err


def test_the_decoded_take_is_what_play_reads(desk, take):
    """The reader the player uses agrees with mcap_ros2's decoding of the same file."""
    from backend.recording.playback import read_recording

    path, frames = take
    rec = read_recording(path, desk)
    with path.open("rb") as fh:
        channels = [
            np.array(m.data)
            for _s, c, _m, m in make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
            if c.topic == "/nutty/channels"
        ]
    np.testing.assert_array_equal(rec.positions, np.stack(channels))
    np.testing.assert_allclose(rec.times, np.arange(TICKS) / RATE, atol=1e-6)
    assert rec.dt == pytest.approx(1 / RATE) and rec.source == "channels" and rec.robot == "nutty_desk"
    assert [k for k, e in enumerate(rec.events) if e] == [k for k, f in enumerate(frames) if f.events]


def test_frames_a_recorder_dropped_are_filled_in_on_the_tick_grid(desk, tmp_path):
    from backend.recording.playback import read_recording

    src = tmp_path / "take.jsonl"
    frames = record(desk, src, FrameRecorder)
    lines = src.read_text().splitlines()
    src.write_text("\n".join(lines[:10] + lines[13:]) + "\n")  # three frames lost on the way
    rec = read_recording(src, desk)
    assert len(rec.times) == TICKS and rec.times[-1] == pytest.approx((TICKS - 1) / RATE)
    yaw = desk.channel_index["head_yaw"]
    truth = np.array([f.position[yaw] for f in frames])
    np.testing.assert_array_equal(
        np.delete(rec.positions[:, yaw], [10, 11, 12]), np.delete(truth, [10, 11, 12])
    )
    np.testing.assert_allclose(rec.positions[10:13, yaw], truth[10:13], atol=2e-4)  # a smooth wave, linearly
    assert [k for k, e in enumerate(rec.events) if e] == [k for k, f in enumerate(frames) if f.events]
