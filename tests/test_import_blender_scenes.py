"""`nutty import` of files that real Blender (bpy, headless) makes from scenes built here: one Blender
process for the module builds them all (tests/blender_rpc.py), then the tests import them.

1. Time zero. Blender's glTF exporter writes a key at frame f as t = f / fps: a scene starting at frame 1
   puts its first key at 1/24 s, and only "Set All glTF Animation Starting at 0" or negative frames
   slide the times back. The clip's t = 0 is the animation's first frame, as the Nutty add-on exports it
   (t = (frame - scene.frame_start) / fps, blender/nutty_blender/clip.py `Timing`). Each import must
   match the add-on's own keys of the same F-curve (`curve_keys` run in Blender) and the F-curve
   evaluated at frame t * fps + frame_start within 0.1 deg, and the report must say how far it shifted.
2. The mapping examples of docs/importing.md, as written, on a default Blender glTF and on Blender's
   BVH export of the same rig (whose every joint has position channels). A rotation listed against
   several DoFs is decomposed in the robot's frame: `"Head": ["head_yaw", "head_pitch"]` gives back the
   yaw and the pitch Blender was keyed with.
"""

from __future__ import annotations

import importlib.util
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from blender_rpc import Blender

from backend.cli import main
from backend.engine.clips import compile_clip

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "importing.md"
FPS = 24
TOLERANCE_DEG = 0.1
# a fast key: 0.8 rad in two frames, then slower ones (frames after the scene's start, rad)
FAST_KEYS = [(0, 0.0), (2, 0.8), (12, -0.3), (24, 0.0)]
# case -> (the scene's frame_start, the glTF exporter's options)
TIME_CASES: dict[str, tuple[int, dict[str, Any]]] = {
    "start 1, defaults": (1, {}),
    "start 1, sampling off (CUBICSPLINE)": (1, {"export_force_sampling": False}),
    "start 1, limit to playback range": (1, {"export_frame_range": True}),
    "start 1, scene mode, not split by object": (
        1,
        {"export_animation_mode": "SCENE", "export_anim_scene_split_object": False},
    ),
    "start 5, all animations starting at 0": (5, {"export_anim_slide_to_zero": True}),
    "start 5, defaults": (5, {}),
    "start 0, defaults": (0, {}),
}


TIME_SCENE = """
reset_scene()
from bpy_extras import anim_utils
scene = bpy.context.scene
start = args["start"]
scene.frame_start, scene.frame_end = start, start + args["keys"][-1][0]
arm = bpy.data.armatures.new("rig")
rig = bpy.data.objects.new("rig", arm)
scene.collection.objects.link(rig)
bpy.context.view_layer.objects.active = rig
rig.select_set(True)
bpy.ops.object.mode_set(mode="EDIT")
bone = arm.edit_bones.new("head_yaw")  # +Z up: the bone's own Y axis is the robot's head_yaw axis
bone.head, bone.tail = (0, 0, 0), (0, 0, 0.1)
bpy.ops.object.mode_set(mode="POSE")
pb = rig.pose.bones["head_yaw"]
pb.rotation_mode = "XYZ"
for frame, value in args["keys"]:
    pb.rotation_euler[1] = value
    pb.keyframe_insert("rotation_euler", index=1, frame=start + frame)
bpy.ops.object.mode_set(mode="OBJECT")
bag = anim_utils.animdata_get_channelbag_for_assigned_slot(rig.animation_data)
fc = next(c for c in bag.fcurves if c.data_path.endswith("rotation_euler") and c.array_index == 1)
notes = []
keys = nutty_blender.clip.curve_keys(fc, nutty_blender.clip.Timing.of(scene), "'head_yaw'", notes)
frames = [start + k / 4 for k in range(4 * args["keys"][-1][0] + 1)]
bpy.ops.export_scene.gltf(filepath=args["path"], export_format="GLB", **args["options"])
result = {"keys": keys, "frames": frames, "values": [fc.evaluate(f) for f in frames],
          "fps": scene.render.fps / scene.render.fps_base}
"""

# A rig in the robot's axes (+Z up, +X forward) with the bones docs/importing.md's examples name, and a
# mesh `Face` with a shape key `smile`. Each bone's own motion is a rotation about world axes:
# "z" yaw, "y" pitch, "x" roll, "zy" yaw then pitch about the turned axis (R_z(a) R_y(b)).
DOCS_SCENE = """
reset_scene()
from mathutils import Matrix, Quaternion, Vector
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, args["frames"][-1]
arm = bpy.data.armatures.new("docs_rig")
rig = bpy.data.objects.new("docs_rig", arm)
scene.collection.objects.link(rig)
bpy.context.view_layer.objects.active = rig
rig.select_set(True)
bpy.ops.object.mode_set(mode="EDIT")
for name, (parent, head, tail) in args["bones"].items():
    b = arm.edit_bones.new(name)
    b.head, b.tail = head, tail
    if parent:
        b.parent = arm.edit_bones[parent]
bpy.ops.object.mode_set(mode="POSE")
for name, (axes, angles) in args["motion"].items():
    pb = rig.pose.bones[name]
    pb.rotation_mode = "QUATERNION"
    rest = pb.bone.matrix_local.to_3x3()
    prev = None
    for frame, values in zip(args["frames"], angles):
        d = Matrix.Identity(3)
        for axis, value in zip(axes, values):
            d = d @ Matrix.Rotation(value, 3, axis.upper())
        q = (rest.inverted() @ d @ rest).to_quaternion()
        if prev is not None and prev.dot(q) < 0:
            q.negate()
        prev = q
        pb.rotation_quaternion = q
        pb.keyframe_insert("rotation_quaternion", frame=frame)
hips = rig.pose.bones["Hips"]
for frame, x in zip(args["frames"], args["hips_x"]):
    hips.location = hips.bone.matrix_local.to_3x3().inverted() @ Vector((x, 0.0, 0.0))
    hips.keyframe_insert("location", frame=frame)
bpy.ops.object.mode_set(mode="OBJECT")
mesh = bpy.data.meshes.new("Face")
mesh.from_pydata([(0.1, 0, 0.35), (0.1, 0.05, 0.35), (0.1, 0, 0.4)], [], [(0, 1, 2)])
face = bpy.data.objects.new("Face", mesh)
scene.collection.objects.link(face)
face.shape_key_add(name="Basis")
smile = face.shape_key_add(name="smile")
smile.data[0].co = (0.1, 0, 0.33)
for frame, v in zip(args["frames"], args["smile"]):
    smile.value = v
    smile.keyframe_insert("value", frame=frame)
bpy.ops.export_scene.gltf(filepath=args["gltf"], export_format="GLB")
bpy.ops.object.select_all(action="DESELECT")
rig.select_set(True)
bpy.context.view_layer.objects.active = rig
bpy.ops.export_anim.bvh(filepath=args["bvh"], frame_start=1, frame_end=args["frames"][-1])
result = {"blender": bpy.app.version_string}
"""
DOCS_FRAMES = [1, 9, 17, 25]
DOCS_BONES = {  # bone -> (parent, head, tail): all in the robot's frame at rest
    "Hips": (None, (0, 0, 0), (0, 0, 0.1)),
    "Spine1": ("Hips", (0, 0, 0.1), (0, 0, 0.2)),
    "Neck": ("Spine1", (0, 0, 0.2), (0, 0, 0.3)),
    "Head": ("Neck", (0, 0, 0.3), (0, 0, 0.4)),
    "LeftEar": ("Head", (0, 0.05, 0.4), (0, 0.05, 0.45)),
    "Tail": ("Hips", (-0.05, 0, 0.05), (-0.15, 0, 0.05)),
}
DOCS_MOTION = {  # bone -> (world axes of its own rotation, applied in order; angles per frame, rad)
    "Spine1": ("z", [(0.0,), (0.3,), (-0.2,), (0.0,)]),
    "Neck": ("y", [(0.0,), (0.2,), (-0.15,), (0.0,)]),
    "Head": ("zy", [(0.0, 0.0), (0.4, 0.2), (-0.3, -0.25), (0.1, 0.1)]),
    "LeftEar": ("x", [(0.0,), (0.3,), (-0.4,), (0.0,)]),
    "Tail": ("z", [(0.0,), (0.5,), (-0.5,), (0.0,)]),
}
DOCS_HIPS_X = [0.0, 0.2, -0.1, 0.0]  # m along the robot's +X
DOCS_SMILE = [0.0, 1.0, 0.2, 0.0]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> dict[str, Any]:
    """Every file this module imports, made by one Blender process; with what Blender says of them."""
    if importlib.util.find_spec("bpy") is None:
        pytest.skip("bpy (Blender as a Python module) is not installed: pip install bpy (Python 3.11)")
    folder = tmp_path_factory.mktemp("blender_scenes")
    blender = Blender()
    try:
        blender.ready()
        out: dict[str, Any] = {"time": {}, "folder": folder}
        for i, (case, (start, options)) in enumerate(TIME_CASES.items()):
            path = folder / f"time{i}.glb"
            got = blender.run(TIME_SCENE, start=start, keys=FAST_KEYS, options=options, path=str(path))
            out["time"][case] = {**got, "path": path, "start": start}
        out["docs"] = blender.run(
            DOCS_SCENE,
            frames=DOCS_FRAMES,
            bones=DOCS_BONES,
            motion=DOCS_MOTION,
            hips_x=DOCS_HIPS_X,
            smile=DOCS_SMILE,
            gltf=str(folder / "docs_rig.glb"),
            bvh=str(folder / "docs_rig.bvh"),
        )
    finally:
        blender.close()
    return out


def run_import(capsys, *argv: Any) -> tuple[dict, dict]:
    """`nutty import ... --json`: (report, clip); exit 0 expected."""
    args = [str(a) for a in argv]
    out = Path(args[args.index("--out") + 1])
    code = main(["import", *args, "--json"])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(stdout), json.loads(out.read_text())


def engine_track(doc: dict, emb, dof: str, times: np.ndarray) -> np.ndarray:
    """The DoF's value as the engine plays the clip (compile_clip), at each time."""
    comp = compile_clip(doc, emb)
    out = np.zeros(emb.n_channels)
    vals = []
    for t in times:
        comp.sample(float(t), np.asarray(emb.rest), out)
        vals.append(out[emb.dof(dof).channels.start])
    return np.array(vals)


# --------------------------------------------------------------------------------------------------
# 1. Time zero
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", list(TIME_CASES))
def test_gltf_time_zero_is_the_first_frame_like_the_addon(scenes, case, tmp_path, capsys, desk):
    scene = scenes["time"][case]
    start, fps = scene["start"], scene["fps"]
    report, doc = run_import(capsys, scene["path"], "--robot", "nutty_desk", "--out", tmp_path / "c.json")
    addon = {"format": "nutty-clip/1", "name": "addon", "tracks": {"head_yaw": scene["keys"]}}
    frames = np.array(scene["frames"])
    whole = frames == np.round(frames)
    if "CUBICSPLINE" in case:  # the exporter approximates Blender's handles: compare at the keys
        whole &= np.isin(frames - start, [f for f, _ in FAST_KEYS])
    t = (frames[whole] - start) / fps
    got = engine_track(doc, desk, "head_yaw", t)
    curve = np.array(scene["values"])[whole]
    by_addon = engine_track(addon, desk, "head_yaw", t)
    assert np.degrees(np.abs(by_addon - curve)).max() < 0.01  # the add-on's keys are the F-curve's
    err_curve = np.degrees(np.abs(got - curve)).max()
    err_addon = np.degrees(np.abs(got - by_addon)).max()
    assert err_curve < TOLERANCE_DEG and err_addon < TOLERANCE_DEG, (err_curve, err_addon)
    assert doc["duration"] == pytest.approx(FAST_KEYS[-1][0] / fps, abs=1e-6)
    shift = report.get("time_shift", 0.0)
    # what Blender wrote: frame / fps, unless the times were slid back to 0
    slid = start <= 0 or "starting at 0" in case
    assert shift == pytest.approx(0.0 if slid else -start / fps, abs=1e-6)
    notes = [n for n in report["notes"] if "first key" in n]
    if shift:
        assert doc["source"]["time_shift"] == shift
        assert len(notes) == 1 and f"shifted by {shift:+.6g} s" in notes[0], report["notes"]
        if "CUBICSPLINE" not in case:  # sampled at every frame: the note names the frame
            assert f"(frame {start} at {FPS} fps)" in notes[0]
        # the clip as the old importer timed it (no shift) is a frame late: far more than the tolerance
        late = engine_track(doc, desk, "head_yaw", t + shift)
        assert np.degrees(np.abs(late - curve)).max() > 5.0
    else:
        assert notes == [] and "time_shift" not in doc["source"]


# --------------------------------------------------------------------------------------------------
# 2. The mapping examples of docs/importing.md
# --------------------------------------------------------------------------------------------------


def docs_mapping_examples(text: str) -> list[dict[str, Any]]:
    """Every mapping example of the page: its ```json blocks, and inline code that is a JSON object
    (`{"Head": ...}`) or one entry of one (`"Head": [...]`); a fragment without "joints" is the
    joints object. Each must parse as it is written."""
    found = re.findall(r"```json\n(.*?)```", text, re.S)
    found += [
        m
        for m in re.findall(r"`([^`\n]+)`", re.sub(r"```.*?```", "", text, flags=re.S))
        if re.match(r'^\{?"[^"]+":\s*\S', m)
    ]
    examples = []
    for snippet in found:
        doc = json.loads(snippet if snippet.lstrip().startswith("{") else "{" + snippet + "}")
        examples.append(doc if "joints" in doc else {"joints": doc})
    return examples


EXAMPLES = docs_mapping_examples(DOCS.read_text())


def test_the_docs_have_the_mapping_examples():
    keys = [set(e["joints"]) for e in EXAMPLES]
    assert {"Neck", "Head"} in keys  # the naive CMU map
    assert {"Head"} in keys  # one joint split between two DoFs
    assert {"Hips.translation"} in keys  # walk the base
    assert any({"Face.weights[smile]", "Tail", "LeftEar"} <= k for k in keys)  # the reference
    heads = [e["joints"]["Head"] for e in EXAMPLES if isinstance(e["joints"].get("Head"), list)]
    assert ["head_yaw", "head_pitch"] in heads  # the documented short form


def expected_dofs(joints: dict[str, Any]) -> set[str]:
    out = set()
    for entry in joints.values():
        for e in entry if isinstance(entry, list) else [entry] if entry is not None else []:
            out.add(e if isinstance(e, str) else e["dof"])
    return out


@pytest.mark.parametrize("fmt", ["glb", "bvh"])
@pytest.mark.parametrize("index", range(len(EXAMPLES)))
def test_docs_mapping_example_imports(scenes, fmt, index, tmp_path, capsys, desk):
    joints = dict(EXAMPLES[index]["joints"])
    if fmt == "bvh":  # a BVH has no meshes: the morph-weight entries are glTF's
        joints = {k: v for k, v in joints.items() if ".weights[" not in k}
        if not joints:
            pytest.skip("an example of morph weights only: glTF's")
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": joints}))
    src = scenes["folder"] / f"docs_rig.{fmt}"
    report, doc = run_import(capsys, src, "--map", mp, "--out", tmp_path / "c.json", *BVH_AXES[fmt])
    assert expected_dofs(joints) <= set(doc["tracks"]), report["unmapped"]
    mapped = {m["source"]: m for m in report["mapped"]}
    if "Tail" in joints:
        assert not any(s.startswith("Tail.") for s in mapped)
    if "Face.weights[smile]" in joints:  # Blender exported the shape keys' action as a 2nd animation
        assert any("'Face.weights[smile]' is not in animation #0" in n for n in report["notes"])
        smile = engine_track(doc, desk, "mouth_open", (np.array(DOCS_FRAMES) - 1) / FPS)
        assert np.abs(smile - DOCS_SMILE).max() < 1e-3


BVH_AXES = {"glb": [], "bvh": ["--up", "z"]}  # Blender writes its BVH in its own +Z-up axes


@pytest.mark.parametrize("fmt", ["glb", "bvh"])
@pytest.mark.parametrize("short", [True, False])
def test_one_rotation_drives_two_dofs_in_the_robot_frame(scenes, fmt, short, tmp_path, capsys, desk):
    """Head turns by R_z(yaw) R_y(pitch) in the robot's frame: listing head_yaw then head_pitch gives
    back the yaw and the pitch at every key, although Blender's glTF and BVH also animate Head's
    translation and scale."""
    split = ["head_yaw", "head_pitch"] if short else [{"dof": "head_yaw"}, {"dof": "head_pitch"}]
    mp = tmp_path / "map.json"
    mp.write_text(json.dumps({"joints": {"Head": split}}))
    src = scenes["folder"] / f"docs_rig.{fmt}"
    report, doc = run_import(capsys, src, "--map", mp, "--out", tmp_path / "c.json", *BVH_AXES[fmt])
    t = (np.array(DOCS_FRAMES) - 1) / FPS
    want = np.array(DOCS_MOTION["Head"][1])
    for j, dof in enumerate(("head_yaw", "head_pitch")):
        got = engine_track(doc, desk, dof, t)
        assert np.degrees(np.abs(got - want[:, j])).max() < TOLERANCE_DEG, (dof, got, want[:, j])
    (head,) = [m for m in report["mapped"] if m["dof"] == "head_yaw"]
    # exact at the keys; between them Blender blends the quaternion's components, a little off R_z R_y
    assert head["source"] == "Head.rotation" and head["swing_max_deg"] < 5.0
    assert report["warnings"] == []
    assert math.isclose(doc["duration"], t[-1], abs_tol=1e-4)  # BVH: Frame Time 0.041667
