"""`nutty import` of mocap BVH: a CMU-style hierarchy (+Y up, the actor facing +Z, ZYX channels).

The file is written here: Hips, both legs, LowerBack, Spine, Spine1, Neck, Neck1, Head and both arms
with realistic OFFSETs; the motion nods the Neck about the file's X axis and turns the Head about its
Y axis. A naive map {"Neck": "neck_pitch", "Head": "head_yaw"} must give the right axes (with
--forward z, the actor's facing becomes the robot's +X) or a swing warning naming the channel (with
the default --forward x the nod is about the robot's X axis, not its pitch axis).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from backend.cli import main
from backend.engine.clips import compile_clip
from backend.importers import import_clip
from backend.importers.rotations import quat_axis_angle, quat_mul, twist_angle

RATE = 120.0
ZYX = "CHANNELS 3 Zrotation Yrotation Xrotation"


def _leg(side: str, sx: float) -> str:
    return f"""  JOINT {side}HipJoint
  {{
    OFFSET 0 0 0
    {ZYX}
    JOINT {side}UpLeg
    {{
      OFFSET {1.65 * sx:.5f} -1.79463 0.83929
      {ZYX}
      JOINT {side}Leg
      {{
        OFFSET {2.46 * sx:.5f} -6.76 0
        {ZYX}
        JOINT {side}Foot
        {{
          OFFSET {2.57 * sx:.5f} -7.06 0
          {ZYX}
          JOINT {side}ToeBase
          {{
            OFFSET {0.16 * sx:.5f} -0.44 2.19
            {ZYX}
            End Site
            {{
              OFFSET 0 0 1.07
            }}
          }}
        }}
      }}
    }}
  }}
"""


def _arm(side: str, sx: float) -> str:
    return f"""        JOINT {side}Shoulder
        {{
          OFFSET 0 0 0
          {ZYX}
          JOINT {side}Arm
          {{
            OFFSET {3.36 * sx:.5f} 0.87 -0.12
            {ZYX}
            JOINT {side}ForeArm
            {{
              OFFSET {4.93 * sx:.5f} 0 0
              {ZYX}
              JOINT {side}Hand
              {{
                OFFSET {3.42 * sx:.5f} 0 0
                {ZYX}
                End Site
                {{
                  OFFSET {0.72 * sx:.5f} 0 0
                }}
              }}
            }}
          }}
        }}
"""


HIERARCHY = f"""HIERARCHY
ROOT Hips
{{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
{_leg("L", 1.0)}{_leg("R", -1.0)}  JOINT LowerBack
  {{
    OFFSET 0 0 0
    {ZYX}
    JOINT Spine
    {{
      OFFSET 0.02 2.04 -0.04
      {ZYX}
      JOINT Spine1
      {{
        OFFSET 0.01 2.06 -0.02
        {ZYX}
        JOINT Neck
        {{
          OFFSET 0 0 0
          {ZYX}
          JOINT Neck1
          {{
            OFFSET -0.0033 1.4612 0.0826
            {ZYX}
            JOINT Head
            {{
              OFFSET -0.0024 1.4843 -0.0592
              {ZYX}
              End Site
              {{
                OFFSET 0 0 0
              }}
            }}
          }}
        }}
{_arm("Left", 1.0)}{_arm("Right", -1.0)}      }}
    }}
  }}
}}
"""

JOINTS = [
    "Hips",
    "LHipJoint",
    "LUpLeg",
    "LLeg",
    "LFoot",
    "LToeBase",
    "RHipJoint",
    "RUpLeg",
    "RLeg",
    "RFoot",
    "RToeBase",
    "LowerBack",
    "Spine",
    "Spine1",
    "Neck",
    "Neck1",
    "Head",
    "LeftShoulder",
    "LeftArm",
    "LeftForeArm",
    "LeftHand",
    "RightShoulder",
    "RightArm",
    "RightForeArm",
    "RightHand",
]


def motion(n: int = 240, seed: int = 1) -> dict[str, np.ndarray]:
    """Per joint (n, 3) ZYX degrees (and Hips (n, 6) position + rotation): a walk-in-place with a nod
    (Neck about X), a head turn (Head about Y) and some motion everywhere else."""
    t = np.arange(n) / RATE
    rng = np.random.default_rng(seed)
    out: dict[str, np.ndarray] = {}
    for j in JOINTS:
        amp = rng.uniform(2, 8, size=3)
        ph = rng.uniform(0, 2 * np.pi, size=3)
        out[j] = amp * np.sin(2 * np.pi * 0.5 * t[:, None] + ph)
    out["Neck"] = np.stack([0 * t, 0 * t, 15 * np.sin(2 * np.pi * 0.5 * t)], axis=1)  # Z Y X: a nod about X
    out["Head"] = np.stack([0 * t, 30 * np.sin(2 * np.pi * 0.25 * t), 3 * np.sin(2 * np.pi * t)], axis=1)
    hips_pos = np.stack(
        [0.5 * np.sin(t), 17.0 + 0.1 * np.sin(4 * t), 20 * t], axis=1
    )  # walking +Z, in inches
    out["Hips"] = np.concatenate([hips_pos, out["Hips"]], axis=1)
    return out


def write_bvh(
    path: Path,
    mot: dict[str, np.ndarray],
    frames: int | str | None = None,
    frame_time: str | None = None,
    hierarchy: str = HIERARCHY,
) -> Path:
    n = len(mot["Hips"])
    rows = np.concatenate([mot[j] for j in JOINTS], axis=1)
    lines = [
        hierarchy + "MOTION",
        f"Frames: {n if frames is None else frames}",
        f"Frame Time: {frame_time or repr(1 / RATE)}",
    ]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def nutty(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def track(doc: dict, emb, dof: str, times: np.ndarray) -> np.ndarray:
    comp = compile_clip(doc, emb)
    out = np.zeros(emb.n_channels)
    vals = []
    for t in times:
        comp.sample(float(t), np.asarray(emb.rest), out)
        vals.append(out[emb.dof(dof).channels.start])
    return np.array(vals)


NAIVE = {"joints": {"Neck": "neck_pitch", "Head": "head_yaw"}}


@pytest.fixture(scope="module")
def cmu(tmp_path_factory) -> tuple[Path, dict[str, np.ndarray]]:
    mot = motion()
    return write_bvh(tmp_path_factory.mktemp("bvh") / "walk.bvh", mot), mot


def test_naive_map_default_axes_warns_about_the_nod(cmu, tmp_path, capsys, desk):
    """+Y up -> +Z up only: the head's turn about Y is the robot's yaw; the neck's nod about the file's
    X axis is the robot's roll axis, so neck_pitch gets almost nothing and a swing warning says so."""
    src, mot = cmu
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps(NAIVE))
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, "import", src, "--map", mp, "--out", out, "--tolerance", "0", "--json")
    assert code == 0, err
    report = json.loads(stdout)
    doc = json.loads(out.read_text())
    times = np.arange(len(mot["Head"])) / RATE
    # head_yaw: the twist about the file's Y (= robot Z) of Rz(0) Ry(yaw) Rx(x) is the yaw exactly
    np.testing.assert_allclose(track(doc, desk, "head_yaw", times), np.radians(mot["Head"][:, 1]), atol=1e-6)
    # neck_pitch: the robot's pitch axis is the file's -Z; the nod is about X, so ~0
    assert np.abs(track(doc, desk, "neck_pitch", times)).max() < 1e-6
    warns = [w for w in report["warnings"] if w["code"] == "swing"]
    assert [w["channel"] for w in warns] == ["Neck.rotation"]
    w = warns[0]
    assert w["swing_max_deg"] == pytest.approx(15.0, abs=0.05)
    np.testing.assert_allclose(np.abs(w["suggested_axis"]), [1, 0, 0], atol=1e-6)
    assert "--forward z" in w["hint"]
    assert "Neck.rotation -> neck_pitch: drops up to 15.0 deg" in err  # --json: warnings on stderr too
    by = {m["source"]: m for m in report["mapped"]}
    assert by["Neck.rotation"]["swing_max_deg"] == pytest.approx(15.0, abs=0.05)
    assert by["Head.rotation"]["swing_max_deg"] == pytest.approx(3.0, abs=0.05)  # Head's X wobble
    assert by["Neck.rotation"]["rest"] == "the OFFSET pose"
    # --strict turns the warning into exit 1 and writes nothing
    out2 = tmp_path / "strict.json"
    code, stdout, err = nutty(capsys, "import", src, "--map", mp, "--out", out2, "--strict")
    assert code == 1 and not out2.exists()
    assert "warning: Neck.rotation -> neck_pitch" in stdout and "--strict" in err


def test_naive_map_forward_z_gives_the_right_axes(cmu, tmp_path, capsys, desk):
    """--forward z: the actor's facing (+Z) becomes the robot's +X, the file's X its +Y (pitch)."""
    src, mot = cmu
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps(NAIVE))
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(
        capsys, "import", src, "--map", mp, "--out", out, "--forward", "z", "--tolerance", "0", "--json"
    )
    assert code == 0, err
    report = json.loads(stdout)
    doc = json.loads(out.read_text())
    times = np.arange(len(mot["Head"])) / RATE
    nod = np.radians(
        mot["Neck"][:, 2]
    )  # + about X: the head goes toward +Z, forward: the robot leans forward
    expect = np.clip(nod, desk.dof("neck_pitch").min, desk.dof("neck_pitch").max)
    np.testing.assert_allclose(track(doc, desk, "neck_pitch", times), expect, atol=1e-6)
    np.testing.assert_allclose(track(doc, desk, "head_yaw", times), np.radians(mot["Head"][:, 1]), atol=1e-6)
    assert report["warnings"] == []
    assert report["conversion"] == {"up": "y", "forward": "z"}


def test_one_source_drives_two_dofs_in_order(tmp_path, desk):
    """ "Head": [head_yaw, head_pitch]: the rotation is split as yaw then pitch (Davenport angles about
    the DoFs' axes in the listed order, what the roll axis would add is the leftover), not two twists."""
    n = 60
    t = np.arange(n) / RATE
    yaw = 40 * np.sin(2 * np.pi * 0.5 * t)
    nod = 20 * np.sin(2 * np.pi * 1.0 * t)  # within head_pitch's limits (-0.5 .. 0.45 rad)
    roll = 12 * np.sin(2 * np.pi * 1.5 * t)
    mot = motion(n)
    mot["Head"] = np.stack([yaw, nod, roll], axis=1)
    # the Head's channels in the robot's chain order: yaw (file Y), pitch (file X), roll (file Z)
    hierarchy = HIERARCHY.replace(
        """OFFSET -0.0024 1.4843 -0.0592
              CHANNELS 3 Zrotation Yrotation Xrotation""",
        """OFFSET -0.0024 1.4843 -0.0592
              CHANNELS 3 Yrotation Xrotation Zrotation""",
    )
    assert hierarchy != HIERARCHY
    src = write_bvh(tmp_path / "head.bvh", mot, hierarchy=hierarchy)
    mapping = {"joints": {"Head": [{"dof": "head_yaw"}, {"dof": "head_pitch"}]}}
    doc, report = import_clip(src, desk, mapping, forward="z", tolerance=0)
    np.testing.assert_allclose(track(doc, desk, "head_yaw", t), np.radians(yaw), atol=1e-7)
    np.testing.assert_allclose(track(doc, desk, "head_pitch", t), np.radians(nod), atol=1e-7)
    m = {x["dof"]: x for x in report["mapped"]}
    assert "split in order head_yaw then head_pitch" in m["head_pitch"]["how"]
    assert m["head_yaw"]["swing_max_deg"] == pytest.approx(
        np.abs(roll).max(), abs=1e-3
    )  # the roll, left over
    # two twists of the same rotation get the pitch wrong by degrees
    q = quat_axis_angle([0, 0, 1], np.radians(yaw))
    q = quat_mul(q, quat_axis_angle([0, 1, 0], np.radians(nod)))
    q = quat_mul(q, quat_axis_angle([1, 0, 0], np.radians(roll)))  # in the robot's frame
    naive = twist_angle(q, [0, 1, 0])
    assert np.degrees(np.abs(naive - np.radians(nod))).max() > 2.0
    # three axes (yaw, pitch, roll) in order: all exact, nothing left over
    mapping3 = {"joints": {"Head": [{"dof": "head_yaw"}, {"dof": "head_pitch"}, {"dof": "head_roll"}]}}
    doc3, report3 = import_clip(src, desk, mapping3, forward="z", tolerance=0)
    np.testing.assert_allclose(track(doc3, desk, "head_pitch", t), np.radians(nod), atol=1e-7)
    np.testing.assert_allclose(track(doc3, desk, "head_roll", t), np.radians(roll), atol=1e-7)
    assert report3["mapped"][0]["swing_max_deg"] < 1e-4


def test_t_pose_first_frame_warns_and_skip_frames(tmp_path, capsys, desk):
    mot = motion(120)
    mot["Neck"][:, 2] += 20.0  # the neck is nodded 20 deg throughout ...
    for j in JOINTS:
        mot[j][0, -3:] = 0.0  # ... but frame 0 is the OFFSET pose (a T-pose)
    src = write_bvh(tmp_path / "tpose.bvh", mot)
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps(NAIVE))
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, "import", src, "--map", mp, "--forward", "z", "--out", out, "--json")
    assert code == 0, err
    warns = json.loads(stdout)["warnings"]
    assert [w["code"] for w in warns] == ["first_frame"]
    assert "neck_pitch" in warns[0]["message"] and "rest pose" in warns[0]["message"]
    assert warns[0]["hint"] == "--skip-frames 1 drops it"
    code, stdout, err = nutty(
        capsys,
        "import",
        src,
        "--map",
        mp,
        "--forward",
        "z",
        "--out",
        out,
        "--json",
        "--skip-frames",
        "1",
        "--tolerance",
        "0",
    )
    assert code == 0, err
    report = json.loads(stdout)
    assert report["warnings"] == []
    doc = json.loads(out.read_text())
    assert doc["tracks"]["neck_pitch"][0]["t"] == 0.0  # the clip starts at the old frame 1
    assert doc["tracks"]["neck_pitch"][0]["v"] == pytest.approx(math.radians(mot["Neck"][1, 2]), abs=1e-7)
    assert report["duration"] == pytest.approx(118 / RATE)


def test_rest_frame_and_root_translation(tmp_path, desk):
    mot = motion(120)
    for j in ("Hips", "LowerBack", "Spine", "Spine1"):  # the neck's parents hold still: its axis stays X
        mot[j][:, -3:] = 0.0
    src = write_bvh(tmp_path / "walk.bvh", mot)
    mapping = {
        "joints": {"Neck": "neck_pitch", "Hips.translation": {"dof": "base_x", "scale": 0.0254}}
    }  # inches -> m
    doc, report = import_clip(src, desk, mapping, forward="z", rest_frame=30, tolerance=0)
    t = np.arange(120) / RATE
    neck = track(doc, desk, "neck_pitch", t)
    assert neck[30] == pytest.approx(0.0, abs=1e-12)  # relative to frame 30
    np.testing.assert_allclose(neck, np.radians(mot["Neck"][:, 2] - mot["Neck"][30, 2]), atol=1e-7)
    # the root walks along the file's +Z, the robot's +X with --forward z; relative to the rest frame
    base = track(doc, desk, "base_x", t)
    expect = np.clip((mot["Hips"][:, 2] - mot["Hips"][30, 2]) * 0.0254, -0.5, 0.5)
    np.testing.assert_allclose(base, expect, atol=1e-7)
    assert report["rest"] == "frame 30"


def test_legacy_bvh_channel_orders_and_report(tmp_path, capsys, desk):
    """Any channel order; joints named after DoFs map by name; the report lists rest and axes."""
    src = tmp_path / "small.bvh"
    src.write_text("""HIERARCHY
ROOT head_yaw
{
  OFFSET 0 0 0
  CHANNELS 3 Xrotation Zrotation Yrotation
  End Site
  {
    OFFSET 0 1 0
  }
}
MOTION
Frames: 3
Frame Time: 0.5
0 0 0
0 0 30
0 0 -20
""")
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, "import", src, "--out", out, "--tolerance", "0")
    assert code == 0, err
    doc = json.loads(out.read_text())
    np.testing.assert_allclose(
        [k["v"] for k in doc["tracks"]["head_yaw"]], np.radians([0, 30, -20]), atol=1e-12
    )
    assert "axes: source +y up and x forward -> robot +Z up, +X forward" in stdout
    assert "rest: the OFFSET pose" in stdout and "BVH channel order XZY" in stdout
