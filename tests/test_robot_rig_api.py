"""What the Blender add-on reads and posts: each joint's frame and axis in GET /api/robot, the visual
meshes as GLB, the trajectory-helper for posted tracks (POST /api/analyze) and the ghost (POST /api/filter)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend.api import create_app
from backend.engine import trajectory
from backend.engine.nmf import MotionFilter
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
INTERACTIVE = ROOT / "robots" / "nutty_desk" / "programs" / "interactive.json"


@pytest.fixture(scope="module")
def client(desk):
    session = EngineSession.create(desk, rate=100, program_text=INTERACTIVE.read_text())
    with TestClient(create_app(session, frontend_dir=None)) as c:
        yield c


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_joint_frames_match_yourdfpy_forward_kinematics(client, desk):
    """Turning a joint by q about the reported axis at the reported origin puts its links where
    yourdfpy's own forward kinematics puts them (all other joints at zero)."""
    import yourdfpy

    robot = client.get("/api/robot").json()
    frames = robot["joint_frames"]
    assert robot["root_links"] == ["base_link"]
    assert list(frames)[:2] == ["body_yaw", "neck_pitch"]  # parents first
    assert frames["head_roll"]["parent_joint"] == "head_pitch" and frames["body_yaw"]["parent_joint"] is None
    assert set(frames["head_roll"]["links"]) == {"head", "eye_left", "eye_right", "mouth"}
    assert frames["eyelid_left"]["parent_joint"] == "head_roll"  # through the fixed eye mount
    by_dof = {d["name"]: d for d in robot["dofs"]}
    assert by_dof["ear_left"]["joint_frame"] == frames["ear_left"]
    assert "joint_frame" not in by_dof["gaze_yaw"]  # symbolic: see its `drives`
    assert robot["joints"] == [j.name for j in desk.joints]  # the old field is unchanged
    urdf = yourdfpy.URDF.load(str(desk.urdf_path))
    for name, f in frames.items():
        origin, rot, axis = np.array(f["origin"]), np.array(f["rotation"]), np.array(f["axis"])
        assert abs(np.linalg.norm(axis) - 1) < 1e-12
        q = 0.37
        urdf.update_cfg({j: (q if j == name else 0.0) for j in urdf.actuated_joint_names})
        child = urdf.joint_map[name].child
        expected = urdf.get_transform(child, "base_link")
        assert np.allclose(expected[:3, 3], origin, atol=1e-12)  # the joint's origin does not move
        assert np.allclose(expected[:3, :3], _rotation(axis, q) @ rot, atol=1e-12)
        assert f["limits"] == [by_dof[name]["min"], by_dof[name]["max"]] if name in by_dof else True


def test_scene_glb_has_every_visual_in_the_base_frame(client, desk):
    import trimesh

    r = client.get("/api/robot/scene.glb")
    assert r.status_code == 200 and r.headers["content-type"] == "model/gltf-binary"
    scene = trimesh.load(io.BytesIO(r.content), file_type="glb")
    names = sorted(scene.graph.nodes_geometry)
    assert "head|0" in names and "torso|2" in names and len(names) == 17  # the URDF's 17 <visual>s
    # glTF is +Y up: the head's box (URDF: 0.07 above the head link, which sits 0.329 + 0.064 up) is at
    # glTF y = robot z
    head, _ = scene.graph["head|0"]
    assert np.allclose(head[:3, 3], [0.0, 0.064 + 0.175 + 0.08 + 0.01 + 0.07, 0.0], atol=1e-9)
    gltf = json.loads(r.content[20 : 20 + int.from_bytes(r.content[12:16], "little")])
    links = {m["extras"]["nutty_link"] for m in gltf["meshes"]}
    assert links == {
        "base_link",
        "torso",
        "chest_led",
        "neck",
        "head",
        "eye_left",
        "eye_right",
        "eyelid_left_link",
        "eyelid_right_link",
        "mouth",
        "ear_left_link",
        "ear_right_link",
    }


def test_analyze_reports_ranges_like_the_trajectory_helper(client, desk):
    rate = 24.0
    t = np.arange(72) / rate
    fast = np.where(t < 1.0, 0.0, 0.9 * np.sin(2 * np.pi * 1.5 * (t - 1.0)))  # still, then too fast
    slow = 0.05 * np.sin(2 * np.pi * 0.2 * t)
    out = client.post(
        "/api/analyze", json={"rate": rate, "tracks": {"head_yaw": fast.tolist(), "ear_left": slow.tolist()}}
    ).json()
    assert out["ok"] is False and out["samples"] == 72 and out["colours"]["jerk"] == "#e5383b"
    assert [r for r in out["ranges"] if r["dof"] == "ear_left"] == []
    dof = desk.dof("head_yaw")
    ref = trajectory.analyze(fast, rate, dof.velocity, dof.acceleration, dof.jerk, dof.min, dof.max)
    codes = np.zeros(72, int)
    for r in out["ranges"]:
        codes[r["start"] : r["end"] + 1] = {"velocity": 1, "acceleration": 2, "jerk": 3, "position": 4}[
            r["kind"]
        ]
    assert np.array_equal(codes, ref.classes[:, 0])
    assert min(r["start"] for r in out["ranges"]) == 25  # the first sample after the still second
    worst = max(out["ranges"], key=lambda r: r["worst_ratio"])
    assert worst["kind"] == "jerk" and worst["worst_ratio"] == pytest.approx(
        np.abs(ref.jerk[:, 0]).max() / dof.jerk
    )
    assert out["dofs"]["head_yaw"]["limits"]["velocity"] == dof.velocity


def test_filter_is_the_stage2_filter_from_the_first_sample(client, desk):
    rate = 30.0
    x = np.r_[np.zeros(5), np.full(40, 0.8)]  # a step: the filter must ease into it within the limits
    body = {"rate": rate, "tracks": {"head_yaw": x.tolist()}}
    out = client.post("/api/filter", json=body).json()
    assert out["preset"] == "program" and out["params"]["preset"] == "D"
    dof = desk.dof("head_yaw")
    f = MotionFilter.from_preset(
        "D",
        1,
        rate,
        vel_limit=2 * dof.velocity,
        acc_limit=dof.acceleration,
        jerk_limit=dof.jerk,
        pmin=dof.min,
        pmax=dof.max,
        x0=[0.0],
    )
    assert np.allclose(out["tracks"]["head_yaw"], f.run(x[:, None]).position[:, 0], atol=1e-12)
    got = np.array(out["tracks"]["head_yaw"])
    assert got[-1] > 0.5 and np.abs(np.diff(got) * rate).max() < dof.velocity
    named = client.post("/api/filter", json={**body, "preset": "W"}).json()
    assert named["preset"] == "W" and named["tracks"]["head_yaw"] != out["tracks"]["head_yaw"]


@pytest.mark.parametrize(
    "body, field, code",
    [
        ({"rate": 24, "tracks": {"nope": [0.0]}}, "tracks.nope", "invalid_track"),
        ({"rate": 24, "tracks": {"mouth": [0.0]}}, "tracks.mouth", "invalid_track"),
        (
            {"rate": 24, "tracks": {"head_yaw": [0.0, 1.0], "ear_left": [0.0]}},
            "tracks.ear_left",
            "invalid_track",
        ),
        ({"rate": 24, "tracks": {"head_yaw": []}}, "tracks.head_yaw", "invalid_track"),
        ({"rate": 0, "tracks": {"head_yaw": [0.0]}}, "rate", "invalid_body"),
        ({"rate": 24, "tracks": {}}, "tracks", "invalid_body"),
        ({"rate": 24, "tracks": {"head_yaw": ["a"]}}, "tracks.head_yaw.0", "invalid_body"),
    ],
)
def test_bad_tracks_are_refused_naming_the_field(client, body, field, code):
    for route in ("/api/analyze", "/api/filter"):
        r = client.post(route, json=body)
        assert r.status_code == 422, r.text
        assert r.json()["detail"]["code"] == code and r.json()["detail"]["field"] == field


def test_filter_without_stage2_asks_for_a_preset(desk):
    from backend.commands.serve import builtin_idle

    program = builtin_idle(desk.name)
    program["nodes"] = [n for n in program["nodes"] if n["type"] != "nmf_stage2"]
    nmf = [e for e in program["edges"] if "nmf" in (e["from"]["node"], e["to"]["node"])]
    src = next(e["from"] for e in nmf if e["to"]["node"] == "nmf")
    dst = next(e["to"] for e in nmf if e["from"]["node"] == "nmf")
    program["edges"] = [e for e in program["edges"] if e not in nmf] + [{"from": src, "to": dst}]
    session = EngineSession.create(desk, rate=100, program=program)
    with TestClient(create_app(session, frontend_dir=None)) as c:
        r = c.post("/api/filter", json={"rate": 24, "tracks": {"head_yaw": [0.0, 0.1]}})
        assert r.status_code == 422 and r.json()["detail"]["code"] == "no_stage2"
        named = c.post("/api/filter", json={"rate": 24, "tracks": {"head_yaw": [0.0, 0.1]}, "preset": "A"})
        assert named.status_code == 200
