"""Build a Blender rig for robots/nutty_desk, animate it, record Blender's own angles and export glTF.

Run with any Python that can `import bpy` (pip install bpy: Blender 5 as a module, Python 3.11):

    python tests/blender_scripts/make_nutty_desk_rig.py OUT_DIR [--urdf robots/nutty_desk/robot.urdf]

The rig follows the conventions `nutty import` expects from Blender (docs/importing.md):

- the scene is the robot's world: +Z up, +X forward, metres; the armature object sits at the origin;
- one bone per joint, its head at the joint's origin in the URDF's zero configuration, pointing up
  the chain (along the joint frame's +Z, the direction the child link grows), so the rest pose is
  the URDF's rest; the ears' bones carry their joint's rest tilt (rpy -0.35 / +0.35 about X);
- bones are named after the joints (rig `joints`) or after the joints' child links (rig `links`);
- the animation keys each bone's *local* rotation (pose-bone quaternion, Blender's default Bezier
  keys), a rotation about the joint's axis plus a small swing about another axis.

For every frame and half frame it records Blender's *evaluated* angle of each joint: from the
evaluated pose matrices, the bone's rotation relative to its parent and to its rest pose, expressed
in world axes (P_rest P_pose^-1 M_pose M_rest^-1), then its twist about the joint's URDF axis in the
world. Writes to OUT_DIR:

    joints.gltf + joints.bin   rig `joints`, Blender's default export settings (as .gltf)
    joints_baked.glb           rig `joints`, .glb with "Bake All Objects Animations"
    joints_cubic.gltf + .bin   rig `joints`, sampling off: Bezier keys -> CUBICSPLINE
    joints_zup.glb             rig `joints`, "+Y Up" off: the file keeps Blender's +Z up (--up z)
    links_skinned.glb          rig `links` with a skinned mesh, exported with the *current pose*
                               as the nodes' rest (export_rest_position_armature off), so only
                               the skin's inverse bind matrices hold the real rest pose
    expected.json              Blender's evaluated angles (rad) at each frame and half frame

Only bpy, mathutils and the standard library are used, so it runs whatever numpy bpy was built with.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import bpy
from mathutils import Matrix, Vector

FPS = 24
LAST_FRAME = 48
CHAIN = ["body_yaw", "neck_pitch", "head_yaw", "head_pitch", "head_roll", "ear_left", "ear_right"]
# Keys: frame -> (angle about the joint axis in rad, swing in rad about a perpendicular axis)
KEYS = {
    "body_yaw": {0: (0.0, 0.0), 12: (0.5, 0.02), 24: (-0.3, 0.0), 36: (0.8, -0.03), 48: (0.0, 0.0)},
    "neck_pitch": {0: (0.0, 0.0), 12: (0.3, 0.05), 24: (-0.2, -0.04), 36: (0.4, 0.0), 48: (0.0, 0.0)},
    "head_yaw": {0: (0.0, 0.0), 12: (-0.5, 0.03), 24: (0.52, 0.0), 36: (0.2, -0.05), 48: (0.0, 0.0)},
    "head_pitch": {0: (0.0, 0.0), 12: (0.3, 0.0), 24: (-0.3, 0.04), 36: (0.2, 0.0), 48: (0.0, 0.0)},
    "head_roll": {0: (0.0, 0.0), 12: (0.2, 0.03), 24: (-0.25, 0.0), 36: (0.1, 0.02), 48: (0.0, 0.0)},
    "ear_left": {0: (0.0, 0.0), 8: (0.5, 0.05), 20: (-0.6, 0.0), 34: (0.3, -0.04), 48: (0.0, 0.0)},
    "ear_right": {0: (0.0, 0.0), 10: (-0.4, 0.0), 22: (0.6, 0.05), 36: (0.2, 0.0), 48: (0.0, 0.0)},
}
POSED_FRAME = 12  # current frame when rig `links` is exported with its pose as the nodes' rest


def rpy_matrix(r: float, p: float, y: float) -> Matrix:
    return Matrix.Rotation(y, 3, "Z") @ Matrix.Rotation(p, 3, "Y") @ Matrix.Rotation(r, 3, "X")


def urdf_frames(urdf: Path) -> dict[str, dict]:
    """Joint -> {pos, rot (world, zero configuration), axis (world), child} for the chain joints."""
    root = ET.parse(urdf).getroot()
    joints = {}
    for j in root.iter("joint"):
        o = j.find("origin")
        xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
        rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
        a = j.find("axis")
        axis = [float(v) for v in (a.get("xyz", "1 0 0") if a is not None else "1 0 0").split()]
        joints[j.get("name")] = {
            "parent": j.find("parent").get("link"),
            "child": j.find("child").get("link"),
            "xyz": Vector(xyz),
            "rot": rpy_matrix(*rpy),
            "axis": Vector(axis).normalized(),
        }
    by_child = {v["child"]: k for k, v in joints.items()}
    out: dict[str, dict] = {}

    def world(name: str) -> tuple[Vector, Matrix]:
        j = joints[name]
        up = by_child.get(j["parent"])
        if up is None:
            return j["xyz"].copy(), j["rot"].copy()
        p, r = world(up)
        return p + r @ j["xyz"], r @ j["rot"]

    for name in CHAIN:
        p, r = world(name)
        out[name] = {
            "pos": p,
            "rot": r,
            "axis": (r @ joints[name]["axis"]).normalized(),
            "child": joints[name]["child"],
            "parent": by_child.get(joints[name]["parent"]),
        }
    return out


def build_rig(name: str, frames: dict[str, dict], bone_names: dict[str, str]) -> bpy.types.Object:
    arm = bpy.data.armatures.new(name)
    ob = bpy.data.objects.new(name, arm)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    for joint in CHAIN:
        f = frames[joint]
        child_joints = [j for j in CHAIN if frames[j]["parent"] == joint]
        length = 0.04
        up = f["rot"] @ Vector((0, 0, 1))
        for cj in child_joints:  # up to the next joint up the chain, if it is further along +Z
            d = (frames[cj]["pos"] - f["pos"]).dot(up)
            if d > 0.02:
                length = d
                break
        b = arm.edit_bones.new(bone_names[joint])
        b.head = f["pos"]
        b.tail = f["pos"] + up * length
        b.align_roll(
            f["rot"] @ Vector((0, -1, 0))
        )  # bone Z = the joint frame's -Y: local axes differ from world
        if f["parent"] is not None:
            b.parent = arm.edit_bones[bone_names[f["parent"]]]
            b.use_connect = False
    bpy.ops.object.mode_set(mode="POSE")
    for joint in CHAIN:
        pb = ob.pose.bones[bone_names[joint]]
        pb.rotation_mode = "QUATERNION"
        rest = pb.bone.matrix_local.to_3x3()
        axis = frames[joint]["axis"]
        perp = axis.orthogonal().normalized()
        prev = None
        for frame, (angle, swing) in KEYS[joint].items():
            d_world = Matrix.Rotation(angle, 3, axis) @ Matrix.Rotation(swing, 3, perp)
            basis = (rest.inverted() @ d_world @ rest).to_quaternion()
            if prev is not None and prev.dot(basis) < 0:
                basis.negate()
            prev = basis
            pb.rotation_quaternion = basis
            pb.keyframe_insert("rotation_quaternion", frame=frame)
    bpy.ops.object.mode_set(mode="OBJECT")
    return ob


def add_skinned_mesh(rig: bpy.types.Object, bone_names: list[str]) -> None:
    """A small box per bone, each skinned to its bone (so the export has a skin)."""
    import bmesh

    mesh = bpy.data.meshes.new("shell")
    bm = bmesh.new()
    groups: list[list[int]] = []
    for bname in bone_names:
        b = rig.data.bones[bname]
        start = len(bm.verts)
        res = bmesh.ops.create_cube(bm, size=0.02)
        for v in res["verts"]:
            v.co = v.co + (b.head_local + b.tail_local) / 2
        groups.append(list(range(start, start + len(res["verts"]))))
    bm.to_mesh(mesh)
    bm.free()
    ob = bpy.data.objects.new("shell", mesh)
    bpy.context.scene.collection.objects.link(ob)
    for bname, idx in zip(bone_names, groups):
        vg = ob.vertex_groups.new(name=bname)
        vg.add(idx, 1.0, "REPLACE")
    mod = ob.modifiers.new("Armature", "ARMATURE")
    mod.object = rig
    ob.parent = rig


def evaluated_angles(
    rig: bpy.types.Object, frames: dict[str, dict], bone_names: dict[str, str], times: list[float]
) -> dict[str, list[float]]:
    """Blender's evaluated angle of every joint at each frame (fractional frames allowed)."""
    scene = bpy.context.scene
    out: dict[str, list[float]] = {j: [] for j in CHAIN}
    for fr in times:
        scene.frame_set(math.floor(fr), subframe=fr - math.floor(fr))
        dg = bpy.context.evaluated_depsgraph_get()
        ev = rig.evaluated_get(dg)
        for joint in CHAIN:
            pb = ev.pose.bones[bone_names[joint]]
            m_pose, m_rest = pb.matrix.to_3x3(), pb.bone.matrix_local.to_3x3()
            if pb.parent is not None:
                p_pose, p_rest = pb.parent.matrix.to_3x3(), pb.parent.bone.matrix_local.to_3x3()
            else:
                p_pose = p_rest = Matrix.Identity(3)
            world = rig.matrix_world.to_3x3()
            d = world @ p_rest @ p_pose.inverted() @ m_pose @ m_rest.inverted() @ world.inverted()
            q = d.to_quaternion()
            a = frames[joint]["axis"]
            ang = 2.0 * math.atan2(q.x * a.x + q.y * a.y + q.z * a.z, q.w)
            ang = (ang + math.pi) % (2 * math.pi) - math.pi
            out[joint].append(ang)
    return out


def export(path: Path, **kw) -> None:
    bpy.ops.export_scene.gltf(filepath=str(path), **kw)


def main(argv: list[str] | None = None) -> int:
    here = Path(__file__).resolve()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--urdf", default=str(here.parents[2] / "robots" / "nutty_desk" / "robot.urdf"))
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    frames = urdf_frames(Path(args.urdf))

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.render.fps_base = 1.0
    scene.frame_start, scene.frame_end = 0, LAST_FRAME
    scene.frame_set(0)

    samples = [k / 2 for k in range(2 * LAST_FRAME + 1)]
    expected: dict = {
        "fps": FPS,
        "frames": samples,
        "times": [f / FPS for f in samples],
        "rigs": {},
        "axes": {j: list(frames[j]["axis"]) for j in CHAIN},
        "keys": {j: {str(k): v for k, v in keys.items()} for j, keys in KEYS.items()},
    }

    # rig `joints`: bones named after the joints
    names = {j: j for j in CHAIN}
    rig = build_rig("nutty_desk_rig", frames, names)
    expected["rigs"]["joints"] = {"bones": names, "angles": evaluated_angles(rig, frames, names, samples)}
    scene.frame_set(0)
    bpy.ops.object.select_all(action="DESELECT")
    export(out / "joints.gltf", export_format="GLTF_SEPARATE")
    export(out / "joints_baked.glb", export_format="GLB", export_bake_animation=True)
    export(out / "joints_cubic.gltf", export_format="GLTF_SEPARATE", export_force_sampling=False)
    export(out / "joints_zup.glb", export_format="GLB", export_yup=False)
    action = rig.animation_data.action if rig.animation_data else None
    arm = rig.data
    bpy.data.objects.remove(rig)
    bpy.data.armatures.remove(arm)
    if action is not None:  # or the next export would carry this rig's action too
        bpy.data.actions.remove(action)

    # rig `links`: bones named after the joints' child links, skinned, posed nodes' rest
    names = {j: frames[j]["child"] for j in CHAIN}
    rig = build_rig("nutty_desk_links", frames, names)
    add_skinned_mesh(rig, [names[j] for j in CHAIN])
    expected["rigs"]["links"] = {"bones": names, "angles": evaluated_angles(rig, frames, names, samples)}
    scene.frame_set(POSED_FRAME)
    export(
        out / "links_skinned.glb",
        export_format="GLB",
        export_rest_position_armature=False,
        export_current_frame=True,
    )
    scene.frame_set(0)

    expected["blender"] = bpy.app.version_string
    for rig in expected["rigs"].values():
        rig["angles"] = {j: [round(a, 10) for a in v] for j, v in rig["angles"].items()}
    (out / "expected.json").write_text(json.dumps(expected) + "\n")
    print(f"wrote {out} (Blender {bpy.app.version_string})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
