"""The gaze source and the IK stage-2 block: directions, intention, speed, arcs, strength, limits, blending."""

from __future__ import annotations

import math

import numpy as np
import pytest

from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import BlockContext
from backend.engine.frames import PartialFrame
from backend.engine.kinematics import chain_for
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession

DT = 0.01
EYE = np.array([0.075, 0.0, 0.085])


def make(emb, type_name, **params):
    cls = BLOCKS[type_name]
    return cls(cls.Params(**params), BlockContext(emb, 1 / DT))


def gaze_error_deg(emb, values, target):
    """Angle (deg) between the head's x axis and the line from the eye point to the target."""
    chain = chain_for(emb, None, "head")
    t = chain.fk(chain.q_from_channels(values))
    eye = t[:3, :3] @ EYE + t[:3, 3]
    u = np.asarray(target, float) - eye
    u /= np.linalg.norm(u)
    return math.degrees(math.acos(min(1.0, float(t[:3, 0] @ u))))


def run_gaze(block, target, n):
    outs = [block.tick(DT, {"target": target}) for _ in range(n)]
    return np.array([o["out"].values for o in outs]), outs


# --- gaze -------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "target,yaw_sign,pitch_sign",
    [
        ([1.0, 0.5, 0.3], +1, +1),  # left (and a bit below the eyes)
        ([1.0, -0.5, 0.3], -1, +1),  # right
        ([1.0, 0.0, 1.0], 0, -1),  # up
        ([1.0, 0.0, -0.2], 0, +1),  # down
    ],
)
def test_gaze_turns_toward_targets_with_the_right_signs(desk, target, yaw_sign, pitch_sign):
    block = make(desk, "gaze")
    frames, outs = run_gaze(block, target, 300)
    last = frames[-1]
    ix = desk.channel_index
    for name in ("head_yaw", "body_yaw"):
        assert np.sign(round(last[ix[name]], 4)) == yaw_sign
    for name in ("head_pitch", "neck_pitch"):
        assert np.sign(round(last[ix[name]], 4)) == pitch_sign
    assert gaze_error_deg(desk, last, target) < 0.5
    assert outs[-1]["on_target"] is True and outs[0]["on_target"] is False
    mask = outs[-1]["out"].mask
    assert sorted(desk.channel_names[i] for i in np.flatnonzero(mask)) == sorted(
        ["head_yaw", "body_yaw", "head_pitch", "neck_pitch"]
    )


def test_gaze_respects_position_limits_for_far_targets(desk):
    block = make(desk, "gaze", weights={"head_yaw": 3.0})
    frames, _ = run_gaze(block, [-1.0, 0.3, 0.3], 400)  # behind, to the left
    assert np.all(frames <= desk.max + 1e-12) and np.all(frames >= desk.min - 1e-12)
    assert gaze_error_deg(desk, frames[-1], [-1.0, 0.3, 0.3]) < 1.0  # body 2.6 + head 1.2 rad reach it


def test_head_leads_and_body_follows(desk):
    block = make(desk, "gaze", follow_lag=0.3)
    frames, _ = run_gaze(block, [1.0, 0.8, 0.3], 400)
    head, body = frames[:, desk.channel_index["head_yaw"]], frames[:, desk.channel_index["body_yaw"]]
    t_head = np.argmax(head >= 0.9 * head[-1])
    t_body = np.argmax(body >= 0.9 * body[-1])
    assert head[-1] > 0.1 and body[-1] > 0.1
    assert t_head + 20 < t_body  # at least 0.2 s earlier
    assert head.max() > 1.2 * head[-1]  # the head first carries the whole turn, then gives it back


def test_speed_limit_is_respected(desk):
    block = make(desk, "gaze", max_speed=1.0, arc_dip=0.0)
    frames, _ = run_gaze(block, [0.2, 1.0, 0.6], 300)
    speed = np.abs(np.diff(frames, axis=0)) / DT
    assert speed.max() <= 1.0 + 1e-9
    assert speed.max() > 0.9  # it does use it
    block = make(desk, "gaze", speed_fraction=0.25, arc_dip=0.0)
    frames, _ = run_gaze(block, [0.2, -1.0, 0.6], 300)
    assert np.all(np.abs(np.diff(frames, axis=0)) / DT <= 0.25 * desk.vel_limit + 1e-9)


def test_arc_dip_only_while_the_gaze_turns(desk):
    ix = [desk.channel_index["head_pitch"], desk.channel_index["neck_pitch"]]
    with_arc, _ = run_gaze(make(desk, "gaze", arc_dip=0.05, arc_max=0.08), [0.5, 1.0, 0.3], 400)
    without, _ = run_gaze(make(desk, "gaze", arc_dip=0.0), [0.5, 1.0, 0.3], 400)
    dip = (with_arc - without)[:, ix].sum(axis=1)
    assert dip[:60].max() > 0.02  # down during the turn
    assert dip.max() <= 0.08 + 1e-9
    assert abs(dip[-1]) < 1e-4  # gone once the turn ends
    up_arc, _ = run_gaze(make(desk, "gaze", arc_dip=0.05), [1.0, 0.0, 1.0], 200)
    up_plain, _ = run_gaze(make(desk, "gaze", arc_dip=0.0), [1.0, 0.0, 1.0], 200)
    assert np.abs(up_arc - up_plain).max() < 1e-12  # a pure pitch move has no arc


def test_strength_blends_from_rest(desk):
    zero = make(desk, "gaze", strength=0.0)
    frames, _ = run_gaze(zero, [1.0, 0.5, 0.3], 100)
    assert np.array_equal(frames[-1], desk.rest)
    full, half = make(desk, "gaze"), make(desk, "gaze")
    for _ in range(150):
        f = full.tick(DT, {"target": [1.0, 0.5, 0.3]})["out"].values
        h = half.tick(DT, {"target": [1.0, 0.5, 0.3], "strength": 0.5})["out"].values
    assert np.allclose(h - desk.rest, 0.5 * (f - desk.rest))


def test_gaze_uses_its_parameter_target_when_unconnected_or_nan(desk):
    block = make(desk, "gaze", target=[1.0, -0.6, 0.4])
    for _ in range(300):
        out = block.tick(DT, {"target": [float("nan"), 0.0, 0.0]})
    assert gaze_error_deg(desk, out["out"].values, [1.0, -0.6, 0.4]) < 0.5


# --- IK ---------------------------------------------------------------------------------------------


def full_frame(emb, **values):
    v = emb.rest.copy()
    for name, x in values.items():
        v[emb.channel_index[name]] = x
    return PartialFrame.full(v)


@pytest.mark.parametrize("target", [[1.0, 0.5, 0.3], [1.0, -0.5, 0.8], [0.6, 0.0, 0.0], [-1.0, 0.2, 0.3]])
def test_ik_look_at_points_the_head_at_the_target(desk, target):
    block = make(desk, "ik")
    frame = full_frame(desk)
    for _ in range(8):
        out = block.tick(DT, {"in": frame, "target": target})["out"]
    assert gaze_error_deg(desk, out.values, target) < 2.0
    assert np.all(out.values <= desk.max + 1e-12) and np.all(out.values >= desk.min - 1e-12)


def test_ik_respects_joint_limits_for_unreachable_targets(desk):
    block = make(desk, "ik")
    frame = full_frame(desk)
    for target in ([0.3, 0.0, 2.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 5.0]):
        block.reset()
        for _ in range(10):
            out = block.tick(DT, {"in": frame, "target": target})["out"]
            assert np.all(out.values <= desk.max + 1e-12) and np.all(out.values >= desk.min - 1e-12)
        ch = desk.channel_index
        if target[2] > 1:
            assert out.values[ch["head_pitch"]] == pytest.approx(
                desk.min[ch["head_pitch"]]
            )  # as far up as it goes


def test_ik_reach_moves_the_tip_to_a_reachable_point(desk):
    chain = chain_for(desk, None, "head")
    goal_q = np.array([0.4, 0.2, -0.3, 0.1, 0.0])
    pose = chain.fk(goal_q)
    goal = pose[:3, :3] @ EYE + pose[:3, 3]
    block = make(desk, "ik", mode="reach", iterations=10)  # the eye point (gaze.eye_offset) reaches
    for _ in range(20):
        out = block.tick(DT, {"in": full_frame(desk), "target": list(goal)})["out"]
    t = chain.fk(chain.q_from_channels(out.values))
    assert np.linalg.norm(t[:3, :3] @ EYE + t[:3, 3] - goal) < 2e-3


def test_ik_passes_through_without_target_or_weight(desk):
    frame = full_frame(desk, head_yaw=0.3, neck_pitch=0.1)
    frame.mask[desk.channel_index["ear_left"]] = False
    for inputs, params in (
        ({"target": [1.0, 0.5, 0.3], "weight": 0.0}, {}),
        ({"target": [float("nan"), 0.0, 0.0]}, {}),
        ({}, {}),
    ):
        block = make(desk, "ik", **params)
        for _ in range(3):
            out = block.tick(DT, {"in": frame, **inputs})["out"]
        assert np.array_equal(out.values, frame.values) and np.array_equal(out.mask, frame.mask)


def test_ik_weight_half_blends_halfway(desk):
    frame = full_frame(desk, head_yaw=-0.2)
    full, half = make(desk, "ik"), make(desk, "ik", weight=0.5)
    for _ in range(5):
        f = full.tick(DT, {"in": frame, "target": [1.0, 0.5, 0.3]})["out"].values
        h = half.tick(DT, {"in": frame, "target": [1.0, 0.5, 0.3]})["out"].values
    assert np.abs(f - frame.values).max() > 0.1
    assert np.allclose(h, frame.values + 0.5 * (f - frame.values))


def test_ik_changes_only_its_dofs_and_resolves_symbolic_ones(desk):
    ch = desk.channel_index
    frame = full_frame(desk, gaze_yaw=0.4, body_yaw=0.2)
    block = make(desk, "ik", dofs=["head_*"])
    for _ in range(10):
        out = block.tick(DT, {"in": frame, "target": [1.0, -0.4, 0.5]})["out"]
    changed = {desk.channel_names[i] for i in np.flatnonzero(out.values != frame.values)}
    assert changed <= {"head_yaw", "head_pitch", "head_roll"}
    assert out.values[ch["gaze_yaw"]] == 0.4 and out.values[ch["body_yaw"]] == 0.2
    assert gaze_error_deg(desk, out.values, [1.0, -0.4, 0.5]) < 2.0  # with gaze_yaw's share of the joints


# --- a whole program ----------------------------------------------------------------------------------


def gaze_program():
    b = ProgramBuilder("gaze demo", "gaze layer over rest, IK stage 2", robot="nutty_desk")
    target = b.expose("gaze_target", type="vec3", default=[1.0, 0.0, 0.3])
    rest = b.node("rest_pose", "rest")
    gaze = b.node("gaze", "gaze")
    mix = b.node(
        "layer_mixer",
        "mix",
        layers=[{"name": "base"}, {"name": "gaze", "mode": "override", "mask": ["stationary:*"]}],
    )
    ik = b.node("ik", "ik")
    b.connect(rest, mix, "out", "base").connect(gaze, mix, "out", "gaze").chain(mix, ik, b.output())
    b.connect(target, gaze, "value", "target").connect(target, ik, "value", "target")
    return b.to_dict()


def test_program_looks_left_when_set_gaze_says_so(desk):
    session = EngineSession.create(desk, rate=100, program=gaze_program())
    frames = list(session.run_headless(50))
    assert abs(frames[-1].position[desk.channel_index["head_yaw"]]) < 0.01
    session.execute({"type": "set_gaze", "target": [1, 0.5, 0.3]})
    frames = list(session.run_headless(200))
    pos = frames[-1].position
    assert pos[desk.channel_index["head_yaw"]] > 0.1 and pos[desk.channel_index["body_yaw"]] > 0.05
    assert gaze_error_deg(desk, pos, [1, 0.5, 0.3]) < 2.0
