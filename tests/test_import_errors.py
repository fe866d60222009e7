"""`nutty import` on bad data and bad mappings: exit 2, one short message naming the sample (index and
time) and the channel, never a traceback; --fill repairs short gaps and says how many samples."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from test_import import G, GltfBuilder, build_gltf, qa, urdf_axis
from test_import_bvh import HIERARCHY, JOINTS, motion, write_bvh

from backend.cli import main

ROOT = Path(__file__).resolve().parents[1]


def nutty(capsys, *argv) -> tuple[int, str, str]:
    code = main(["import", *[str(a) for a in argv]])
    out, err = capsys.readouterr()
    return code, out, err


def assert_short_error(code: int, err: str, *needles: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err
    assert err.startswith("nutty: error: ")
    assert len(err) < 700 and err.count("\n") <= 4, err
    for n in needles:
        assert n in err, (n, err)


@pytest.fixture()
def walk(tmp_path) -> tuple[Path, dict[str, np.ndarray]]:
    return tmp_path / "walk.bvh", motion(60)


def column(joint: str, channel: int = 2) -> int:
    """Column of a joint's ZYX channel (0 Z, 1 Y, 2 X) in the CMU-style file (Hips has 6 channels)."""
    col = 0
    for j in JOINTS:
        if j == joint:
            return col + (3 if j == "Hips" else 0) + channel
        col += 6 if j == "Hips" else 3
    raise KeyError(joint)


# --------------------------------------------------------------------------------------------------
# BVH
# --------------------------------------------------------------------------------------------------


def test_bvh_nan_frame(walk, tmp_path, capsys):
    path, mot = walk
    mot["Neck"][12, 2] = np.nan
    write_bvh(path, mot)
    out = tmp_path / "clip.json"
    code, _, err = nutty(capsys, path, "--out", out, "--map", _naive(tmp_path))
    assert_short_error(code, err, "frame 12 (t = 0.1000 s)", "Neck.Xrotation", "nan", "--fill")
    assert not out.exists()


def test_bvh_inf_and_text_values(walk, tmp_path, capsys):
    path, mot = walk
    mot["Head"][3, 1] = np.inf
    write_bvh(path, mot)
    code, _, err = nutty(capsys, path, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "frame 3 (t = 0.0250 s)", "Head.Yrotation", "inf")
    text = path.read_text().splitlines()
    i = text.index("MOTION") + 3 + 5  # frame 5
    text[i] = text[i].replace(text[i].split()[7], "oops", 1)
    path.write_text("\n".join(text))
    code, _, err = nutty(capsys, path, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "frame 5", "'oops', not a number")


@pytest.mark.parametrize(
    "header, needles",
    [
        ("Frames: nan", ["Frames:", "whole number", "'nan'"]),
        ("Frames: -3", ["Frames:", ">= 0"]),
        ("Frame Time: nan", ["Frame Time:", "finite number", "'nan'"]),
        ("Frame Time: inf", ["Frame Time:", "'inf'"]),
        ("Frame Time: 0", ["Frame Time:", "> 0"]),
    ],
)
def test_bvh_bad_motion_header(walk, tmp_path, capsys, header, needles):
    path, mot = walk
    write_bvh(path, mot)
    text = path.read_text()
    key = header.split(":")[0] + ":"
    line = next(x for x in text.splitlines() if x.startswith(key))
    path.write_text(text.replace(line, header, 1))
    code, _, err = nutty(capsys, path, "--out", tmp_path / "c.json")
    assert_short_error(code, err, *needles)


def test_bvh_nan_offset(walk, tmp_path, capsys):
    path, mot = walk
    write_bvh(
        path, mot, hierarchy=HIERARCHY.replace("OFFSET -0.0033 1.4612 0.0826", "OFFSET -0.0033 nan 0.0826")
    )
    code, _, err = nutty(capsys, path, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "joint 'Neck1'", "OFFSET", "'nan'")


def test_bvh_frames_missing(walk, tmp_path, capsys):
    path, mot = walk
    write_bvh(path, mot, frames=61)
    code, _, err = nutty(capsys, path, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "'Frames: 61'", "60 complete frame(s)")


@pytest.mark.parametrize("mode", ["linear", "hold"])
def test_bvh_fill(walk, tmp_path, capsys, mode):
    path, mot = walk
    truth = mot["Neck"][:, 2].copy()
    mot["Neck"][20:23, 2] = np.nan  # a 3-frame gap
    mot["Head"][0, 1] = np.nan  # at the very start: held from the next good frame
    write_bvh(path, mot)
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(
        capsys,
        path,
        "--out",
        out,
        "--map",
        _naive(tmp_path),
        "--forward",
        "z",
        "--fill",
        mode,
        "--tolerance",
        "0",
        "--json",
    )
    assert code == 0, err
    report = json.loads(stdout)
    assert f"--fill {mode}: filled 4 sample(s) (Neck.Xrotation 3, Head.Yrotation 1)" in report["notes"]
    doc = json.loads(out.read_text())
    neck = np.array([k["v"] for k in doc["tracks"]["neck_pitch"]])
    if mode == "linear":
        expect = np.interp(np.arange(20, 23), [19, 23], [truth[19], truth[23]])
    else:
        expect = np.full(3, truth[19])
    np.testing.assert_allclose(np.degrees(neck[20:23]), np.clip(expect, -20.05, 28.7), atol=1e-5)
    # a gap longer than --max-gap is still an error naming it
    code, _, err = nutty(capsys, path, "--out", out, "--fill", mode, "--max-gap", "2")
    assert_short_error(code, err, "frames 20-22", "Neck.Xrotation", "--max-gap 2")


def _naive(tmp_path: Path) -> Path:
    p = tmp_path / "naive.json"
    p.write_text(json.dumps({"joints": {"Neck": "neck_pitch", "Head": "head_yaw"}}))
    return p


# --------------------------------------------------------------------------------------------------
# glTF, CSV
# --------------------------------------------------------------------------------------------------


def _gltf_with(tmp_path: Path, values: np.ndarray, times=None, name="head_yaw", rest=None) -> Path:
    b = GltfBuilder()
    n = b.node(name)
    if rest is not None:
        b.gltf.nodes[n].rotation = rest
    t = np.linspace(0, 1, len(values)) if times is None else np.asarray(times, float)
    b.channel(n, "rotation", t, values, "VEC4")
    return b.save(tmp_path / "bad.gltf")


def _yaw_keys(n: int = 6) -> np.ndarray:
    return qa(G(urdf_axis("head_yaw")), np.linspace(0, 0.6, n))


def test_gltf_nan_quaternion(tmp_path, capsys):
    q = _yaw_keys()
    q[3] = [np.nan, 0, 0, 1]
    src = _gltf_with(tmp_path, q)
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "key 3 (t = 0.6 s)", "head_yaw.rotation", "not finite", "--fill")


def test_gltf_zero_quaternion(tmp_path, capsys):
    q = _yaw_keys()
    q[2] = 0.0
    code, _, err = nutty(capsys, _gltf_with(tmp_path, q), "--out", tmp_path / "c.json")
    assert_short_error(code, err, "key 2 (t = 0.4 s)", "head_yaw.rotation", "length 0")


def test_gltf_nan_time_and_rest(tmp_path, capsys):
    src = _gltf_with(tmp_path, _yaw_keys(3), times=[0.0, np.nan, 1.0])
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "head_yaw.rotation", "key 1 has time nan")
    # JSON has no NaN; 1e999 is valid JSON and reads as inf
    src = _gltf_with(tmp_path, _yaw_keys(3), rest=[0.0, 0.123456789, 0.0, 1.0])
    src.write_text(src.read_text().replace("0.123456789", "1e999"))
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "node 'head_yaw'", "rest rotation", "inf")


@pytest.mark.parametrize("mode", ["linear", "hold"])
def test_gltf_fill(tmp_path, capsys, mode):
    q = _yaw_keys(6)  # 0 .. 0.6 rad in steps of 0.12 at t = 0, 0.2, ... 1.0
    q[2] = np.nan
    out = tmp_path / "clip.json"
    code, stdout, err = nutty(capsys, _gltf_with(tmp_path, q), "--out", out, "--fill", mode)
    assert code == 0, err
    assert f"--fill {mode}: filled 1 sample(s) (head_yaw.rotation 1)" in stdout
    vals = [k["v"] for k in json.loads(out.read_text())["tracks"]["head_yaw"]]
    assert vals[2] == pytest.approx(0.24 if mode == "linear" else 0.12, abs=1e-6)


def test_csv_nan_cell(tmp_path, capsys):
    src = tmp_path / "keys.csv"
    src.write_text("time,head_yaw,neck_pitch\n0,0.1,0\n0.5,nan,0.2\n1.0,-0.2,0.3\n")
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "line 3 (t = 0.5 s)", "head_yaw", "'nan'")
    out = tmp_path / "c.json"
    code, stdout, err = nutty(capsys, src, "--out", out, "--fill", "linear")
    assert code == 0, err
    assert [k["t"] for k in json.loads(out.read_text())["tracks"]["head_yaw"]] == [0.0, 1.0]
    assert "skipped 1 non-finite cell(s) (head_yaw 1)" in stdout


def test_real_cli_has_no_traceback(walk, tmp_path):
    """The installed entry point, in a fresh process: `Frames: nan` and a NaN frame."""
    path, mot = walk
    mot["Spine"][7, 0] = np.nan
    write_bvh(path, mot)
    for text in (path.read_text(), path.read_text().replace("Frames: 60", "Frames: nan")):
        path.write_text(text)
        proc = subprocess.run(
            [sys.executable, "-m", "backend.cli", "import", str(path), "--out", str(tmp_path / "c.json")],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=120,
        )
        assert proc.returncode == 2, proc.stderr
        assert "Traceback" not in proc.stderr and proc.stdout == ""
        assert proc.stderr.count("\n") <= 3 and len(proc.stderr) < 500, proc.stderr
        assert (
            "frame 7 (t = 0.0583 s): Spine.Zrotation is nan" in proc.stderr
            or "Frames: expected a whole number, got 'nan'" in proc.stderr
        )


# --------------------------------------------------------------------------------------------------
# Mapping files that cannot silently misfire
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "joints, needles",
    [
        ({"Nek": "neck_pitch"}, ["joints.Nek", "no animated source 'Nek'", "closest: Neck"]),
        ({"Neck": "neck_pich"}, ["joints.Neck", "no DoF 'neck_pich'", "closest: neck_pitch"]),
        ({"Head": "head_yaw", "Head.rotation": "head_pitch"}, ["'Head' and 'Head.rotation'"]),
        (
            {"Neck": "neck_pitch", "Neck1": "neck_pitch"},
            ["DoF 'neck_pitch' is driven by both 'Neck' and 'Neck1'"],
        ),
        ({"Head": [{"dof": "head_yaw"}, {"dof": "head_yaw"}]}, ["listed twice"]),
        ({"Head": [{"dof": "head_yaw"}, {"dof": "body_yaw"}]}, ["head_yaw then body_yaw", "parallel"]),
        (
            {"Hips.translation": [{"dof": "base_x"}, {"dof": "base_y"}]},
            ["only a rotation can drive several DoFs"],
        ),
        ({"Neck": {"dof": "neck_pitch", "axs": [0, 1, 0]}}, ["unknown keys ['axs']"]),
    ],
)
def test_mapping_errors(walk, tmp_path, capsys, joints, needles):
    path, mot = walk
    write_bvh(path, mot)
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": joints}))
    code, _, err = nutty(capsys, path, "--out", tmp_path / "c.json", "--map", mp)
    assert_short_error(code, err, *needles)


def test_gltf_unknown_node_and_errors_stay_short(tmp_path, capsys):
    src = build_gltf(tmp_path / "anim.gltf")
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": {"head_yawn": "head_yaw"}}))
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json", "--map", mp)
    assert_short_error(code, err, "no animated source 'head_yawn'", "closest: head_yaw")


def test_cli_options_validated(tmp_path, capsys):
    src = build_gltf(tmp_path / "anim.gltf")
    with pytest.raises(SystemExit) as exc:
        main(["import", str(src), "--out", str(tmp_path / "c.json"), "--max-gap", "0"])
    assert exc.value.code == 2
    assert "--max-gap" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["import", str(src), "--out", str(tmp_path / "c.json"), "--skip-frames", "nan"])
    assert exc.value.code == 2
    assert "argument --skip-frames: expected a whole number, got 'nan'" in capsys.readouterr().err
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json", "--up", "z", "--forward", "z")
    assert_short_error(code, err, "perpendicular")
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json", "--skip-frames", "99")
    assert_short_error(code, err, "--skip-frames 99", "distinct key time")


def test_gltf_quaternion_components_stay_finite_in_json(tmp_path, capsys):
    """A glTF whose skin matrix is singular or NaN: still a short error."""
    b = GltfBuilder()
    n = b.node("head_yaw")
    b.channel(n, "rotation", [0.0, 1.0], _yaw_keys(2), "VEC4")
    ibm = b.accessor(np.full((1, 16), np.nan), "SCALAR")
    b.gltf.accessors[ibm].type = "MAT4"
    b.gltf.accessors[ibm].count = 1
    b.gltf.skins = [pygltflib.Skin(joints=[n], inverseBindMatrices=ibm)]
    src = b.save(tmp_path / "skin.gltf")
    code, _, err = nutty(capsys, src, "--out", tmp_path / "c.json")
    assert_short_error(code, err, "inverse bind matrix of joint 'head_yaw'")
