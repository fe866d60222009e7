"""The physics preview (backend/sim): the URDF in MuJoCo, what the motors make of a motion, contacts.

Checked against physics the tests can work out by hand: a 2 kg head 0.12 m from a 0.6 N·m neck cannot
hold itself past ~0.26 rad (m g r sin q), and two arms 0.2 m long on yaw joints 0.36 m apart cross only
when both turn in.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yourdfpy

pytest.importorskip("mujoco")

from backend.api_types.physics import PhysicsReport
from backend.engine.embodiment import load_embodiment
from backend.sim.model import build, gains_for
from backend.sim.motions import clip_motion, program_motion
from backend.sim.report import physics_report
from backend.sim.world import SimWorld

ASSETS = Path(__file__).parent / "assets" / "robots"
ROBOTS = Path(__file__).parent.parent / "robots"

#: A nod far faster than the neck can carry the head: 0.6 rad in 0.15 s, then back.
FAST_NOD = {
    "format": "nutty-clip/1",
    "name": "fast_nod",
    "robot": "heavy_head",
    "relative": True,
    "tracks": {
        "neck": [
            {"t": 0, "v": 0},
            {"t": 0.15, "v": 0.6},
            {"t": 0.3, "v": -0.3},
            {"t": 0.45, "v": 0.5},
            {"t": 0.6, "v": 0},
        ]
    },
}


def test_the_urdf_compiles_with_its_own_ranges_and_stands_still(desk):
    """Ranges in radians as the URDF gives them (MuJoCo reads degrees by default), guessed inertia said
    in the notes, and the robot holds its rest pose without touching itself or the floor."""
    sim = build(desk, gains_for(desk, None))
    world = SimWorld(sim)
    low, high = world.joint_range
    urdf = yourdfpy.URDF.load(str(desk.urdf_path), load_meshes=False, build_scene_graph=False)
    for j, name in enumerate(sim.joints):
        joint = urdf.joint_map[name]
        assert (low[j], high[j]) == pytest.approx((joint.limit.lower, joint.limit.upper)), name
        assert sim.effort[j] == pytest.approx(joint.limit.effort), name
    assert any("inertia from geometry" in note for note in sim.notes)
    # the head sits on the neck through two shapeless gimbal links: touching there is the joint itself
    assert any(note.endswith("never in contact: neck / head") for note in sim.notes)
    rest = desk.joint_positions(desk.rest.copy())
    world.reset(rest)
    assert world.follow(rest, 1.0) == []
    assert np.abs(world.positions() - rest).max() < 0.005


def test_a_weak_neck_cannot_follow_a_fast_nod():
    """Raw, the head falls past what the neck can hold: large error, the motor saturated; the program's
    stage 2 (preset D) slows the nod into something the neck nearly tracks."""
    emb = load_embodiment(ASSETS / "heavy_head")
    motion = clip_motion(emb, "fast_nod", FAST_NOD)  # the robot has no program: the built-in clip stage
    report = PhysicsReport.model_validate(
        physics_report(build(emb, gains_for(emb, None)), motion.raw, motion.filtered, motion.rate)
    )
    raw, filtered = report.raw.joints["neck"], report.filtered.joints["neck"]
    assert raw.peak_error > 0.3 and raw.saturated > 0.3 and raw.peak_effort == pytest.approx(1.0)
    assert report.raw.saturated_joints == ["neck"] and report.raw.worst_joint == "neck"
    assert filtered.peak_error < raw.peak_error / 3 and filtered.saturated < raw.saturated / 3
    assert raw.peak_torque == pytest.approx(0.6, abs=1e-3) and raw.effort_limit == 0.6


def test_a_posture_pair_collides_with_the_right_links():
    emb = load_embodiment(ASSETS / "two_arms")
    world = SimWorld(build(emb, gains_for(emb, None)))
    names = list(world.sim.joints)

    def goals(*postures: str) -> np.ndarray:
        q = np.zeros(len(names))
        for posture in postures:
            for joint, value in emb.postures[posture].items():
                q[names.index(joint)] = value
        return q

    for alone in ("left_in", "right_in"):
        world.reset(np.zeros(len(names)))
        assert world.follow(goals(alone), 1.0) == [], alone
    world.reset(np.zeros(len(names)))
    (hit,) = world.follow(goals("left_in", "right_in"), 1.0)
    assert hit.links == ("left_arm", "right_arm") and hit.depth > 0.001
    assert 0.1 < hit.position[0] < 0.3  # between the two shoulders (x = 0 and 0.36 m)


def test_the_bundled_idle_program_tracks_within_0_05_rad(desk):
    program = json.loads((ROBOTS / "nutty_desk" / "programs" / "idle.json").read_text())
    motion = program_motion(desk, "idle", program, 6.0)
    report = physics_report(build(desk, gains_for(desk, None)), motion.raw, motion.filtered, motion.rate)
    worst = {name: j["peak_error"] for name, j in report["filtered"]["joints"].items()}
    assert max(worst.values()) < 0.05, worst
    assert report["filtered"]["contacts"] == [] and report["filtered"]["saturated_joints"] == []


def test_a_table_plane_counts_contacts_but_never_with_the_base():
    """heavy_head's head (a 7 cm ball 0.22 m up) clears a table 0.14 m up at rest; nodded 0.8 rad
    forward it would sink 4 cm into the table, which holds it up instead. The base, under the table
    too, is welded to the world."""
    emb = load_embodiment(ASSETS / "heavy_head")
    sim = build(emb, gains_for(emb, None), table=0.14)
    assert sim.table_z == pytest.approx(sim.floor_z + 0.14)
    world = SimWorld(sim)
    world.reset(np.zeros(1))
    assert world.follow(np.zeros(1), 0.5) == []
    (hit,) = world.follow(np.array([0.8]), 1.0)
    assert hit.links == ("head", "table") and 0 < hit.depth < 0.005
    # resting on the table (touching from 0.41 rad: 0.1 + 0.12 cos q - 0.07 = 0.14), short of the goal
    assert 0.38 < world.positions()[0] < 0.6


def test_a_clip_from_anywhere_plays_in_its_robots_default_program(desk):
    """The robot's program (as `nutty serve` picks it), wherever the clip file lies; none: the built-in
    stage."""
    from backend.commands.sim import clip_stage_program  # lazy: a command module

    interactive = json.loads((ROBOTS / "nutty_desk" / "programs" / "interactive.json").read_text())
    assert clip_stage_program(desk) == interactive
    assert clip_stage_program(load_embodiment(ASSETS / "heavy_head")) is None
