"""`nutty import`: glTF/GLB, BVH and CSV animations -> nutty-clip/1 clips (assets generated here)."""

from __future__ import annotations

import base64
import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from backend.cli import main
from backend.engine.clips import Clip, compile_clip
from backend.engine.embodiment import load_embodiment
from backend.importers import decimate, import_clip
from backend.importers.mapping import quat_axis_angle, quat_mul, swing_twist, twist_angle

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "robots" / "nutty_desk" / "robot.urdf"


@pytest.fixture(scope="module")
def emb():
    return load_embodiment("nutty_desk")


def urdf_axis(joint: str) -> np.ndarray:
    for j in ET.parse(URDF).getroot().iter("joint"):
        if j.get("name") == joint:
            return np.array([float(x) for x in j.find("axis").get("xyz").split()])
    raise KeyError(joint)


def nutty(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def sample(doc: dict, emb, dof: str, t: float) -> float:
    comp = compile_clip(doc, emb)
    out = np.zeros(emb.n_channels)
    comp.sample(t, np.asarray(emb.rest), out)
    return float(out[emb.dof(dof).channels.start])


# --------------------------------------------------------------------------------------------------
# glTF writer (test asset generator)
# --------------------------------------------------------------------------------------------------


class GltfBuilder:
    def __init__(self):
        self.blob = bytearray()
        self.gltf = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"))
        self.samplers: list = []
        self.channels: list = []

    def node(self, name: str) -> int:
        self.gltf.nodes.append(pygltflib.Node(name=name))
        return len(self.gltf.nodes) - 1

    def accessor(
        self, arr: np.ndarray, type_: str, *, stride_pad: int = 0, ctype: int = 5126, normalized: bool = False
    ) -> int:
        arr = np.asarray(arr)
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[type_]
        arr = arr.reshape(-1, width)
        if ctype == 5126:
            data = arr.astype("<f4")
        else:  # normalised int16
            data = np.round(arr * 32767).astype("<i2")
        while len(self.blob) % 4:
            self.blob.append(0)
        offset = len(self.blob)
        elem = data.itemsize * width
        stride = elem + stride_pad
        for row in data:
            self.blob += row.tobytes() + b"\0" * stride_pad
        view = pygltflib.BufferView(
            buffer=0,
            byteOffset=offset,
            byteLength=stride * len(data),
            byteStride=stride if stride_pad else None,
        )
        self.gltf.bufferViews.append(view)
        self.gltf.accessors.append(
            pygltflib.Accessor(
                bufferView=len(self.gltf.bufferViews) - 1,
                componentType=ctype,
                count=len(data),
                type=type_,
                normalized=normalized,
            )
        )
        return len(self.gltf.accessors) - 1

    def channel(self, node: int, path: str, times, values, type_: str, interp: str = "LINEAR", **kw) -> None:
        s = pygltflib.AnimationSampler(
            input=self.accessor(np.asarray(times), "SCALAR"),
            output=self.accessor(values, type_, **kw),
            interpolation=interp,
        )
        self.samplers.append(s)
        self.channels.append(
            pygltflib.AnimationChannel(
                sampler=len(self.samplers) - 1, target=pygltflib.AnimationChannelTarget(node=node, path=path)
            )
        )

    def save(self, path: Path, mode: str = "datauri") -> Path:
        self.gltf.animations = [
            pygltflib.Animation(name="wave", samplers=self.samplers, channels=self.channels)
        ]
        blob = bytes(self.blob)
        if mode == "glb":
            self.gltf.buffers = [pygltflib.Buffer(byteLength=len(blob))]
            self.gltf.set_binary_blob(blob)
            self.gltf.save_binary(str(path))
        elif mode == "bin":
            bin_path = path.with_suffix(".bin")
            bin_path.write_bytes(blob)
            self.gltf.buffers = [pygltflib.Buffer(byteLength=len(blob), uri=bin_path.name)]
            self.gltf.save_json(str(path))
        else:
            uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
            self.gltf.buffers = [pygltflib.Buffer(byteLength=len(blob), uri=uri)]
            self.gltf.save_json(str(path))
        return path


def qa(axis, angle) -> np.ndarray:
    return quat_axis_angle(np.asarray(axis, float), np.asarray(angle, float))


def G(robot_vec) -> np.ndarray:
    """A robot-frame vector (+Z up) in glTF's axes (+Y up): robot (x, y, z) = glTF (x, -z, y)."""
    x, y, z = robot_vec
    return np.array([x, z, -y], dtype=float)


def dq(axis, angle, rate) -> np.ndarray:
    """Time derivative of the quaternion of a rotation by `angle` about `axis` turning at `rate`."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([axis * math.cos(angle / 2) / 2, [-math.sin(angle / 2) / 2]]) * rate


YAW_T, YAW_A = [0.0, 0.5, 1.0], [0.0, 0.6, -0.3]
PITCH_T, PITCH_A = [0.0, 0.4, 0.8], [0.1, -0.2, 0.3]
ROLL_T, ROLL_A, ROLL_W = [0.0, 0.5, 1.0], [0.0, 0.3, 0.1], [0.0, 0.8, -0.4]
NECK_T, NECK_A = [0.0, 1.2], [0.2, -0.4]
EAR_T, EAR_A = [0.0, 0.6], [0.3, -0.5]
FACE_T, FACE_V, FACE_IN, FACE_OUT = [0.0, 0.6, 1.0], [0.0, 0.8, 0.2], [0.0, 1.5, -0.5], [2.0, -1.0, 0.0]


def build_gltf(path: Path, mode: str = "datauri") -> Path:
    b = GltfBuilder()
    yaw, pitch, roll = b.node("head_yaw"), b.node("Head-Pitch"), b.node("head_roll")
    neck, ear, tail, face = b.node("Neck"), b.node("ear_left"), b.node("Tail"), b.node("Face")
    # LINEAR about the URDF axis, output with a padded byteStride
    b.channel(yaw, "rotation", YAW_T, qa(G(urdf_axis("head_yaw")), YAW_A), "VEC4", stride_pad=8)
    # STEP, with a swing about a perpendicular axis that must be dropped
    swing = qa(G([1, 0, 0]), 0.25)
    q_pitch = quat_mul(qa(G(urdf_axis("head_pitch")), PITCH_A), swing)
    b.channel(pitch, "rotation", PITCH_T, q_pitch, "VEC4", interp="STEP")
    # CUBICSPLINE rotation: [in, value, out] triplets
    ax = G(urdf_axis("head_roll"))
    trip = []
    for a, w in zip(ROLL_A, ROLL_W):
        d = dq(ax, a, w)
        trip += [d, qa(ax, a), d]
    b.channel(roll, "rotation", ROLL_T, np.array(trip), "VEC4", interp="CUBICSPLINE")
    b.channel(neck, "rotation", NECK_T, qa(G([0, 1, 0]), NECK_A), "VEC4")
    b.channel(neck, "translation", NECK_T, np.array([[0, 0, 0.1], [0, 0, 0.2]]), "VEC3")
    # normalised int16 quaternions
    b.channel(
        ear, "rotation", EAR_T, qa(G(urdf_axis("ear_left")), EAR_A), "VEC4", ctype=5122, normalized=True
    )
    b.channel(tail, "rotation", [0.0, 1.0], qa(G([0, 0, 1]), [0.0, 1.0]), "VEC4")
    # CUBICSPLINE morph-target weight (scalar): exact bezier keys
    wt = np.array([[i, v, o] for i, v, o in zip(FACE_IN, FACE_V, FACE_OUT)]).reshape(-1)
    b.channel(face, "weights", FACE_T, wt, "SCALAR", interp="CUBICSPLINE")
    return b.save(path, mode)


def hermite(t, times, v, tin, tout):
    k = int(np.searchsorted(times, t, side="right") - 1)
    dt = times[k + 1] - times[k]
    s = (t - times[k]) / dt
    return (
        (2 * s**3 - 3 * s**2 + 1) * v[k]
        + (s**3 - 2 * s**2 + s) * dt * tout[k]
        + (-2 * s**3 + 3 * s**2) * v[k + 1]
        + (s**3 - s**2) * dt * tin[k + 1]
    )


# --------------------------------------------------------------------------------------------------
# glTF
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["datauri", "bin", "glb"])
def test_gltf_import_cli(tmp_path, capsys, emb, mode):
    src = build_gltf(tmp_path / ("anim.glb" if mode == "glb" else "anim.gltf"), mode)
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, "import", src, "--robot", "nutty_desk", "--out", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    Clip.model_validate(doc)
    compile_clip(doc, emb)
    assert doc["format"] == "nutty-clip/1" and doc["name"] == "anim" and doc["anchors"] == {}
    assert doc["source"]["format"] == "gltf" and doc["source"]["animation"] == "wave"
    assert doc["duration"] == pytest.approx(1.2)
    tracks = doc["tracks"]
    assert set(tracks) == {"head_yaw", "head_pitch", "head_roll", "ear_left"}

    yaw = tracks["head_yaw"]
    assert [k["interp"] for k in yaw] == ["linear"] * 3
    np.testing.assert_allclose([k["t"] for k in yaw], np.float32(YAW_T), atol=1e-7)
    np.testing.assert_allclose([k["v"] for k in yaw], YAW_A, atol=1e-6)

    pitch = tracks["head_pitch"]  # normalised name, STEP, swing dropped
    assert [k["interp"] for k in pitch] == ["constant"] * 3
    np.testing.assert_allclose([k["v"] for k in pitch], PITCH_A, atol=1e-6)

    ear = tracks["ear_left"]  # int16 normalised: precision ~3e-5
    np.testing.assert_allclose([k["v"] for k in ear], EAR_A, atol=2e-4)

    # CUBICSPLINE rotation: sampled densely, smooth (bezier) keys through the samples; midpoint matches
    # the Hermite evaluation
    roll = tracks["head_roll"]
    assert all(k["interp"] == "bezier" for k in roll) and len(roll) > 3
    ax = G(urdf_axis("head_roll"))
    qs = np.array([qa(ax, a) for a in ROLL_A])
    ds = np.array([dq(ax, a, w) for a, w in zip(ROLL_A, ROLL_W)])
    for t in (0.25, 0.75, 0.6):
        q = hermite(t, ROLL_T, qs, ds, ds)
        expect = twist_angle(q / np.linalg.norm(q), ax)[0]
        assert sample(doc, emb, "head_roll", t) == pytest.approx(expect, abs=1e-3)
    np.testing.assert_allclose(sample(doc, emb, "head_roll", 0.5), 0.3, atol=1e-6)

    # report: mapped and unmapped channels
    assert "head_yaw.rotation -> head_yaw" in stdout
    assert "Head-Pitch.rotation -> head_pitch" in stdout and "ignoring case" in stdout
    assert "Tail.rotation: no DoF of that name" in stdout
    assert "Neck.rotation: no DoF" in stdout
    assert "Neck.translation: translation channel" in stdout
    assert "Face.weights[0]" in stdout


def test_gltf_mapping_file_and_json_report(tmp_path, capsys, emb):
    src = build_gltf(tmp_path / "anim.gltf")
    mapping = tmp_path / "map.json"
    mapping.write_text(
        json.dumps(
            {
                "joints": {
                    "Neck": {"dof": "neck_pitch", "scale": 0.5},
                    "Face.weights[0]": "mouth_open",
                    "Tail": None,
                }
            }
        )
    )
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(
        capsys,
        "import",
        src,
        "--robot",
        "nutty_desk",
        "--out",
        out,
        "--map",
        mapping,
        "--name",
        "wave_clip",
        "--json",
    )
    assert code == 0, err
    report = json.loads(stdout)
    doc = json.loads(out.read_text())
    assert doc["name"] == "wave_clip"
    neck = doc["tracks"]["neck_pitch"]
    np.testing.assert_allclose([k["v"] for k in neck], np.array(NECK_A) * 0.5, atol=1e-6)
    by_src = {m["source"]: m for m in report["mapped"]}
    assert by_src["Neck.rotation"]["dof"] == "neck_pitch" and by_src["Neck.rotation"]["scale"] == 0.5
    assert "mapping file" in by_src["Neck.rotation"]["how"]
    unmapped = {u["source"]: u["reason"] for u in report["unmapped"]}
    assert "ignored by the mapping file" in unmapped["Tail.rotation"]
    assert "translation" in unmapped["Neck.translation"]
    # CUBICSPLINE scalar -> bezier keys with free handles reproduce the Hermite curve
    mouth = doc["tracks"]["mouth_open"]
    assert all(k["interp"] == "bezier" and k["right_type"] == "free" for k in mouth)
    assert mouth[0]["right"] == pytest.approx([0.2, FACE_OUT[0] * 0.2], abs=1e-6)
    assert mouth[1]["left"] == pytest.approx([-0.2, -FACE_IN[1] * 0.2], abs=1e-6)
    for t in (0.1, 0.3, 0.45, 0.8, 0.95):
        expect = hermite(t, np.float32(FACE_T), FACE_V, FACE_IN, FACE_OUT)
        assert sample(doc, emb, "mouth_open", t) == pytest.approx(expect, abs=1e-4)
    assert report["clamped_total"] == 0
    assert report["duration"] == pytest.approx(1.2)


def test_gltf_animation_choice_and_clamp(tmp_path, emb):
    b = GltfBuilder()
    n = b.node("head_yaw")
    b.channel(n, "rotation", [0.0, 1.0], qa(G([0, 0, 1]), [0.0, 2.0]), "VEC4")  # 2.0 > limit 1.2
    src = b.save(tmp_path / "a.gltf")
    doc, report = import_clip(src, emb, animation="0")
    assert doc["tracks"]["head_yaw"][1]["v"] == pytest.approx(emb.dof("head_yaw").max)
    assert report["clamped"] == {"head_yaw": 1} and report["clamped_total"] == 1
    with pytest.raises(ValueError, match="no animation 'nope'"):
        import_clip(src, emb, animation="nope")
    with pytest.raises(ValueError, match="out of range"):
        import_clip(src, emb, animation=3)


# --------------------------------------------------------------------------------------------------
# BVH, CSV
# --------------------------------------------------------------------------------------------------

BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT head_yaw
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT HeadPitch
    {
      OFFSET 0 5 0
      CHANNELS 3 Xrotation Yrotation Zrotation
      End Site
      {
        OFFSET 0 3 0
      }
    }
  }
}
MOTION
Frames: {n}
Frame Time: 0.1
{rows}
"""


def test_bvh_import(tmp_path, capsys, emb):
    n = 11
    # BVH is +Y up: the robot's yaw axis (+Z) is the file's +Y, its pitch axis (+Y) the file's -Z
    yaw = np.linspace(0, 40, n)  # degrees, about Y (last in ZXY) after a swing about X
    pitch = 20 * np.sin(np.linspace(0, math.pi, n))  # about -Z (last in XYZ) after a swing about X
    rows = []
    for i in range(n):
        rows.append(" ".join(str(x) for x in [1, 2, 3, 5, 0, 0, 0, 15, yaw[i], 10, 0, -pitch[i]]))
    src = tmp_path / "mocap.bvh"
    src.write_text(BVH.replace("{n}", str(n)).replace("{rows}", "\n".join(rows)))
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, "import", src, "--out", out, "--tolerance", "0")
    assert code == 0, err
    doc = json.loads(out.read_text())
    compile_clip(doc, emb)
    y = doc["tracks"]["head_yaw"]
    # BVH frames are samples of a motion: smooth bezier keys through them (they were linear keys)
    assert len(y) == n and all(k["interp"] == "bezier" for k in y)
    np.testing.assert_allclose([k["t"] for k in y], np.arange(n) * 0.1, atol=1e-12)
    np.testing.assert_allclose([k["v"] for k in y], np.radians(yaw), atol=1e-9)
    np.testing.assert_allclose([k["v"] for k in doc["tracks"]["head_pitch"]], np.radians(pitch), atol=1e-9)
    assert "Hips.translation: translation channel" in stdout
    assert "Hips.rotation: no DoF" in stdout
    # decimation: the linear yaw ramp needs only its two ends
    doc2, _report = import_clip(src, emb, tolerance=1e-3)
    assert len(doc2["tracks"]["head_yaw"]) == 2
    assert sample(doc2, emb, "head_yaw", 0.55) == pytest.approx(math.radians(22), abs=1e-3)
    assert len(doc2["tracks"]["head_pitch"]) <= n


def test_csv_import(tmp_path, capsys, emb):
    src = tmp_path / "keys.csv"
    src.write_text("time,head_yaw,Mouth,neck_pitch\n0,0.1,neutral,0\n0.5,0.3,smile,\n1.0,-0.2,open,0.9\n")
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, "import", src, "--out", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    compile_clip(doc, emb)
    assert [k["v"] for k in doc["tracks"]["head_yaw"]] == [0.1, 0.3, -0.2]
    assert doc["tracks"]["head_yaw"][0]["interp"] == "linear"
    assert [k["v"] for k in doc["tracks"]["mouth"]] == ["neutral", "smile", "open"]
    neck = doc["tracks"]["neck_pitch"]
    assert [k["t"] for k in neck] == [0.0, 1.0] and neck[1]["v"] == 0.5  # clamped to the limit 0.5
    assert "clamped 1 key value" in stdout
    code, _, err = nutty(capsys, "import", src, "--out", out, "--interp", "constant")
    assert code == 0 and json.loads(out.read_text())["tracks"]["head_yaw"][0]["interp"] == "constant"


# --------------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------------


def test_errors(tmp_path, capsys):
    out = tmp_path / "clip.json"
    code, _, err = nutty(capsys, "import", tmp_path / "missing.gltf", "--out", out)
    assert code == 2 and "no such file" in err
    weird = tmp_path / "anim.fbx"
    weird.write_text("x")
    code, _, err = nutty(capsys, "import", weird, "--out", out)
    assert code == 2 and "unknown format" in err
    src = build_gltf(tmp_path / "anim.gltf")
    code, _, err = nutty(capsys, "import", src, "--robot", "no_such_robot", "--out", out)
    assert code == 2 and "no_such_robot" in err
    empty = tmp_path / "empty.gltf"
    pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"), nodes=[pygltflib.Node(name="a")]).save_json(
        str(empty)
    )
    code, _, err = nutty(capsys, "import", empty, "--out", out)
    assert code == 2 and "no animations" in err
    bad_map = tmp_path / "map.json"
    bad_map.write_text(json.dumps({"joints": {"Neck": {"dof": "neck_pitch", "axis": [0, 0, 0]}}}))
    code, _, err = nutty(capsys, "import", src, "--out", out, "--map", bad_map)
    assert code == 2 and "axis" in err
    nothing = tmp_path / "nothing.csv"
    nothing.write_text("time,foo\n0,1\n")
    code, _, err = nutty(capsys, "import", nothing, "--out", out)
    assert code == 2 and "no channel" in err and "foo" in err
    assert not out.exists()


# --------------------------------------------------------------------------------------------------
# Swing-twist, decimation
# --------------------------------------------------------------------------------------------------


def test_swing_twist():
    rng = np.random.default_rng(3)
    for _ in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(-math.pi + 1e-3, math.pi - 1e-3)
        q = qa(axis, angle)
        assert twist_angle(q, axis)[0] == pytest.approx(angle, abs=1e-12)
        perp = np.cross(axis, rng.normal(size=3))
        perp /= np.linalg.norm(perp)
        swing = qa(perp, rng.uniform(-1.2, 1.2))
        for combined in (quat_mul(swing, q), quat_mul(q, swing)):
            assert twist_angle(combined, axis)[0] == pytest.approx(angle, abs=1e-9)
            sw, tw = swing_twist(combined, axis)
            np.testing.assert_allclose(quat_mul(sw, tw), combined, atol=1e-12)
            assert abs(np.dot(sw[:3], axis)) < 1e-9  # the swing has no component about the axis
    # a sequence is unwrapped across +-pi
    angles = np.linspace(2.5, 4.0, 7)
    np.testing.assert_allclose(twist_angle(qa([0, 0, 1], angles), [0, 0, 1]), angles, atol=1e-12)


def test_decimate():
    t = np.linspace(0, 1, 101)
    v = np.where(t < 0.5, t, 1 - t)
    tk, vk = decimate(t, v, 1e-6)
    assert list(tk) == [0.0, 0.5, 1.0]
    tk, vk = decimate(t, np.sin(6 * t), 1e-3)
    assert 3 < len(tk) < 101
    assert np.max(np.abs(np.interp(t, tk, vk) - np.sin(6 * t))) <= 1e-3 + 1e-12


def test_yaml_mapping_translation_to_linear_dof(tmp_path, emb):
    src = build_gltf(tmp_path / "anim.gltf")
    mapping = tmp_path / "map.yaml"
    # axes are in the robot's frame: the node's glTF +Z (0.1, 0.2) is the robot's -Y
    mapping.write_text(
        "joints:\n  Neck.translation: {dof: base_x, axis: [0, -1, 0], scale: 2.0, offset: -0.1}\n"
        "  Tail: {dof: body_yaw}\n"
    )
    doc, report = import_clip(src, emb, mapping)
    np.testing.assert_allclose([k["v"] for k in doc["tracks"]["base_x"]], [0.1, 0.3], atol=1e-6)
    np.testing.assert_allclose([k["v"] for k in doc["tracks"]["body_yaw"]], [0.0, 1.0], atol=1e-6)
    assert {m["source"]: m["dof"] for m in report["mapped"]}["Neck.translation"] == "base_x"
    # an unknown DoF is an error naming the closest DoFs (it used to leave the channel unmapped)
    with pytest.raises(ValueError, match=r"robot 'nutty_desk' has no DoF 'body_yw' \(closest: body_yaw"):
        import_clip(src, emb, {"joints": {"Tail": "body_yw"}})
