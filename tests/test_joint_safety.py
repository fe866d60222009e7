"""The joints the motors get stay within their limits, whatever the channels do (docs/safety.md).

Joint values are computed here from the frames and the robot's own files (tests/joint_truth.py), not
by the code under test. Three robots with symbolic DoFs: nutty_desk (gaze and blink on top of the
head, neck, body and eyelids), pan_tilt_eyes (a jaw no own DoF drives) and lift_arm (a prismatic
lift, coefficients of both signs, a continuous wrist).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from joint_truth import TEST_ROBOTS, JointTruth, joint_truth
from test_safe_swaps import program

from backend.engine.embodiment import Embodiment, load_embodiment
from backend.engine.runtime import Sink
from backend.engine.safety import SafetyNet
from backend.session import EngineSession

ROBOTS = {
    "nutty_desk": "nutty_desk",
    "pan_tilt_eyes": TEST_ROBOTS / "pan_tilt_eyes",
    "lift_arm": TEST_ROBOTS / "lift_arm",
}
_EMB: dict[str, tuple[Embodiment, JointTruth]] = {}


def robot(name: str) -> tuple[Embodiment, JointTruth]:
    if name not in _EMB:
        _EMB[name] = (load_embodiment(ROBOTS[name]), joint_truth(ROBOTS[name]))
    return _EMB[name]


def drive(emb, targets: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray, SafetyNet]:
    """The net's output channels and joints for a stream of program frames."""
    net = SafetyNet(emb, rate)
    outs, joints = [], []
    for x in targets:
        outs.append(net.step(x))
        joints.append(net.joint_out.copy())
    return np.array(outs), np.array(joints), net


# --- random streams -------------------------------------------------------------------------------

SEGMENT = st.tuples(
    st.sampled_from(["step", "noise", "sine", "hold"]), st.integers(3, 60), st.integers(0, 2**31 - 1)
)


def stream(emb, segments, rate: float) -> np.ndarray:
    """Program frames: postures (steps anywhere up to 1.5x beyond each channel's range), noise, chirps
    and holds, one segment after another, on every continuous channel."""
    cont = emb.continuous_mask
    lo, hi = emb.min, emb.max
    span = np.where(cont, hi - lo, 0.0)
    frames, x = [], emb.rest.copy()
    for kind, n, seed in segments:
        rng = np.random.default_rng(seed)
        if kind == "step":
            x = np.where(cont, lo - 0.25 * span + 1.5 * span * rng.random(emb.n_channels), x)
            frames += [x] * n
        elif kind == "noise":
            for _ in range(n):
                x = np.where(cont, x + 0.2 * span * rng.standard_normal(emb.n_channels), x)
                frames.append(x.copy())
        elif kind == "sine":
            f = rng.uniform(0.2, 8.0)
            amp = np.where(cont, 0.8 * span * rng.random(emb.n_channels), 0.0)
            centre = x
            frames += [centre + amp * np.sin(2 * np.pi * f * k / rate) for k in range(n)]
            x = frames[-1]
        else:
            frames += [x] * n
    return np.array(frames)


@pytest.mark.parametrize("name", list(ROBOTS))
@pytest.mark.parametrize("rate", [30.0, 100.0, 1000.0])
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(segments=st.lists(SEGMENT, min_size=1, max_size=6))
def test_random_streams_keep_every_joint_within_its_limits(name, rate, segments):
    emb, truth = robot(name)
    targets = stream(emb, segments, rate)
    out, joints, _ = drive(emb, targets, rate)
    # The joints the net reports are the ones it enforces...
    truth.assert_within(joints, rate, "net.joint_out")
    # ...and the frame's channels compose to them wherever the joint has an own channel.
    q = truth.compose(emb, out)
    has_own = np.array([o is not None for o in truth.own])
    np.testing.assert_allclose(q[:, has_own], joints[:, has_own], atol=1e-12)
    truth.assert_within(q[:, has_own], rate, "composed from the frames", only=has_own)


def test_a_feasible_composition_passes_through_bit_for_bit():
    emb, _truth = robot("nutty_desk")
    rate = 100.0
    t = np.arange(400) / rate
    targets = np.tile(emb.rest, (len(t), 1))
    ci = emb.channel_index
    u = np.minimum(t / 2.0, 1.0)
    fade_in = u**3 * (10 - 15 * u + 6 * u**2)  # smooth to the second derivative
    targets[:, ci["gaze_yaw"]] = 0.3 * np.sin(2 * np.pi * 0.3 * t) * fade_in
    targets[:, ci["head_yaw"]] = 0.2 * np.sin(2 * np.pi * 0.2 * t) * fade_in
    out, _joints, net = drive(emb, targets, rate)
    assert np.array_equal(out, targets)
    assert not net.joint_corrections.any() and net.corrected_ticks == 0


def test_a_joint_without_its_own_dof_is_limited_in_the_frames_joints():
    emb, truth = robot("pan_tilt_eyes")
    rate = 100.0
    x = emb.rest.copy()
    x[emb.channel_index["talk"]] = 0.5  # the jaw at its upper limit...
    x[emb.channel_index["yawn"]] = 0.6  # ...and a yawn adds 0.48 rad on top
    out, joints, net = drive(emb, np.tile(x, (200, 1)), rate)
    jaw = truth.names.index("jaw")
    assert joints[:, jaw].max() == pytest.approx(0.5) and joints[:, jaw].max() <= 0.5
    truth.assert_within(joints, rate)
    assert net.stats()["joint_corrections"]["jaw"] > 0
    # The channels say what the program asked (nothing to carry a jaw correction back onto).
    assert truth.compose(emb, out)[-1, jaw] > 0.9


# --- through the engine's paths (nutty_desk) ------------------------------------------------------


def run(session, n: int) -> list:
    return list(session.run_headless(n))


def joints_of(frames, emb, truth) -> np.ndarray:
    return truth.compose(emb, np.array([f.position for f in frames]))


def test_the_bow_posture_no_longer_bends_the_neck_past_its_limit(desk):
    """The issue's case: neck_pitch 0.5 + gaze_pitch 0.45 composed to 0.709 rad (limit 0.5) for 3 s."""
    truth = joint_truth("nutty_desk")
    session = EngineSession.create(desk, rate=100.0, program=program("interactive"))
    frames = run(session, 20)
    session.execute({"type": "go_posture", "posture": "neutral"})
    session.embodiment.postures["bow"] = {"neck_pitch": 0.5, "gaze_pitch": 0.45, "head_pitch": 0.45}
    try:
        session.execute({"type": "go_posture", "posture": "bow"})
        frames += run(session, 400)
    finally:
        del session.embodiment.postures["bow"]
    q = joints_of(frames, desk, truth)
    truth.assert_within(q, 100.0, "bow")
    neck = truth.names.index("neck_pitch")
    assert q[:, neck].max() == pytest.approx(0.5, abs=1e-9)  # it goes there, and no further
    status = session.engine.stats()["safety"]
    assert status["joint_corrections"]["neck_pitch"] > 0  # counted, not hidden
    np.testing.assert_allclose(np.array([f.joints for f in frames]), q, atol=1e-12)


def test_a_puppet_stream_on_joint_and_gaze_channels_stays_within_the_joints(desk):
    truth = joint_truth("nutty_desk")
    session = EngineSession.create(desk, rate=100.0, program=program("interactive"))
    frames = run(session, 10)
    rng = np.random.default_rng(7)
    for _k in range(150):
        v = rng.uniform(-1, 1, 3)
        session.execute(
            {
                "type": "puppet",
                "values": {"body_yaw": 2.5 * v[0], "gaze_yaw": 1.5 * v[1], "head_yaw": 1.2 * v[2]},
            }
        )
        frames += run(session, 2)
    session.execute({"type": "puppet", "release": True})
    frames += run(session, 200)
    truth.assert_within(joints_of(frames, desk, truth), 100.0, "puppet")


@pytest.mark.parametrize("to", ["breathe-anything", "idle", "greet"])
def test_swaps_resets_and_stop_all_keep_the_joints_within_limits(desk, to):
    truth = joint_truth("nutty_desk")
    session = EngineSession.create(desk, rate=100.0, program=program("interactive"))
    frames = run(session, 20)
    session.execute({"type": "set_gaze", "target": [0.4, 0.6, -0.2]})
    frames += run(session, 150)
    session.load_program(program(to))
    frames += run(session, 150)
    session.load_program(program("interactive"))
    frames += run(session, 50)
    session.execute({"type": "play_clip", "clip": "nod"})
    frames += run(session, 30)
    session.execute({"type": "stop_all"})
    frames += run(session, 60)
    session.execute({"type": "reset", "fade": 0.2})
    frames += run(session, 150)
    parked: list = []  # the frames park() ticks itself, as a driver receives them
    sink = session.engine.add_sink(Sink("parked", parked.append, max_queue=10_000))
    assert session.engine.park(timeout=3.0)["reached_rest"]
    session.engine.remove_sink(sink)
    assert parked and parked[0].seq == frames[-1].seq + 1
    truth.assert_within(joints_of(frames + parked, desk, truth), 100.0, to)


def test_the_recorder_writes_the_joints_the_motors_get(desk, tmp_path):
    from backend.drivers.recorder import FrameRecorder

    session = EngineSession.create(desk, rate=100.0, program=program("interactive"))
    rec = session.engine.add_sink(FrameRecorder(desk, tmp_path / "r.jsonl"))
    frames = run(session, 30)
    session.engine.remove_sink(rec)
    rows = [json.loads(line) for line in (tmp_path / "r.jsonl").read_text().splitlines()]
    assert list(rows[-1]["joints"]) == desk.joint_names
    assert rows[-1]["joints"]["neck_pitch"] == frames[-1].joints[desk.joint_names.index("neck_pitch")]


# --- warnings when a posture or clip is saved -------------------------------------------------------


def test_saving_a_posture_or_clip_that_leaves_a_joint_range_warns_naming_the_joint(desk, tmp_path):
    from fastapi.testclient import TestClient

    from backend.api import create_app
    from backend.commands.serve import builtin_idle

    session = EngineSession.create(desk, rate=100, program=builtin_idle(desk.name))
    session.library.folder = tmp_path
    with TestClient(create_app(session, frontend_dir=None)) as client:
        bow = client.put(
            "/api/postures/bow", json={"values": {"neck_pitch": 0.5, "gaze_pitch": 0.45, "head_pitch": 0.45}}
        ).json()
        assert bow["saved"] == "bow"
        neck, head = bow["warnings"]
        # 0.5 + 0.6 x 0.45 = 0.77 against 0.5; 0.45 + 0.4 x 0.45 = 0.63 against 0.45
        assert "'neck_pitch'" in neck and "0.770" in neck and "0.27 above its upper limit 0.5" in neck
        assert "'head_pitch'" in head and "0.18 above its upper limit 0.45" in head
        assert client.put(
            "/api/postures/fine", json={"values": {"neck_pitch": 0.2, "gaze_pitch": 0.3}}
        ).json() == {"saved": "fine"}
        clip = {
            "format": "nutty-clip/1",
            "tracks": {
                "gaze_yaw": [{"t": 0.0, "v": 0.0}, {"t": 1.0, "v": 1.5}],
                "head_yaw": [{"t": 0.0, "v": 0.0}, {"t": 1.0, "v": 1.0}],
            },
        }
        saved = client.put("/api/clips/look_far", json=clip).json()
        (warning,) = saved["warnings"]
        # head_yaw joint: 1.0 + 0.7 x 1.5 = 2.05 against 1.2, at the clip's end
        assert "'head_yaw'" in warning and "2.050 rad at 1.00 s" in warning and "0.85 above" in warning


# --- random postures, swaps and resets through the engine, on the two test robots -----------------


@pytest.mark.parametrize("name", ["pan_tilt_eyes", "lift_arm"])
@settings(
    max_examples=6,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_random_postures_swaps_and_resets_keep_the_joints_within_limits(name, data):
    from backend.commands.serve import builtin_idle

    emb, truth = robot(name)
    cont = [d for d in emb.dofs if d.type.value == "continuous"]
    session = EngineSession.create(emb, rate=100.0, program=builtin_idle(emb.name))
    frames = run(session, 5)
    try:
        for k in range(data.draw(st.integers(1, 3), label="postures")):
            values = {d.name: data.draw(st.floats(d.min, d.max), label=d.name) for d in cont}
            emb.postures[f"random{k}"] = values
            session.execute(
                {
                    "type": "go_posture",
                    "posture": f"random{k}",
                    "duration": data.draw(st.floats(0.05, 1.0), label="duration"),
                }
            )
            frames += run(session, data.draw(st.integers(10, 150), label="ticks"))
            if data.draw(st.booleans(), label="swap"):
                session.load_program(builtin_idle(emb.name))
                frames += run(session, data.draw(st.integers(5, 60), label="after swap"))
        session.execute({"type": "reset", "fade": 0.2})
        frames += run(session, 150)
    finally:
        for key in [p for p in emb.postures if p.startswith("random")]:
            del emb.postures[key]
    joints = np.array([f.joints for f in frames])
    truth.assert_within(joints, 100.0, f"{name} joints")
    has_own = np.array([o is not None for o in truth.own])
    q = truth.compose(emb, np.array([f.position for f in frames]))
    truth.assert_within(q[:, has_own], 100.0, f"{name} composed", only=has_own)
