"""A Blender (bpy) process that tests drive line by line: each stdin line is JSON `{"code": str, "args": {...}}`;
the code runs in one persistent namespace (bpy, the registered add-on `nutty_blender`, `args`, and the
helpers below) and sets `result`; the answer is one stdout line `{"ok": true, "result": ...}` or
`{"ok": false, "error": traceback}`. Everything else Blender prints goes to stderr, so the protocol's
stdout stays clean. Run with a Python that can `import bpy` (tests/blender_rpc.py starts it).
"""

from __future__ import annotations

import json
import math
import os
import sys
import traceback
from pathlib import Path

protocol = os.fdopen(os.dup(1), "w", buffering=1)  # our stdout; fd 1 (Blender's C prints) -> stderr
os.dup2(2, 1)
sys.stdout = sys.stderr

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "blender"))

import bpy  # noqa: E402 (after sys.path is set up for Blender)
import nutty_blender  # noqa: E402 (after sys.path is set up for Blender)
from mathutils import Matrix  # noqa: E402 (after sys.path is set up for Blender)

nutty_blender.register()


def reset_scene() -> None:
    """An empty scene with the settings of a new file (minus its default objects): tests do not see each
    other's rigs, keys, markers, frame range or Nutty settings."""
    if nutty_blender.live.LINK.running:
        nutty_blender.live.LINK.stop()
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    for action in list(bpy.data.actions):
        bpy.data.actions.remove(action)
    scene = bpy.context.scene
    scene.timeline_markers.clear()
    scene.render.fps, scene.render.fps_base = 24, 1.0
    scene.frame_start, scene.frame_end = 1, 250  # a new file's
    scene.frame_set(1)
    for name in ("server_url", "clip_name", "export_target", "export_path", "ghost_preset", "ghost_offset"):
        scene.nutty.property_unset(name)
    scene.nutty.ranges.clear()
    bpy.context.window_manager.nutty_token = ""


def key(rig, dof: str, frames: list[tuple[float, object]]) -> None:
    """Key DoF `dof` of the rig at (frame, value) pairs: a bone's Y rotation (rad), or the armature's
    property of that name (symbolic, display and sound DoFs)."""
    bone = rig.pose.bones.get(dof)
    for frame, value in frames:
        if bone is not None:
            bone.rotation_euler[1] = value
            bone.keyframe_insert("rotation_euler", index=1, frame=frame)
        else:
            rig[dof] = value
            rig.keyframe_insert(f'["{dof}"]', frame=frame)


def joint_angles(rig, joints: dict, times: list[float]) -> dict[str, list[float]]:
    """Blender's evaluated angle (rad) of each joint at each frame (fractional frames allowed), from the
    evaluated pose matrices: the rotation of the joint's bone relative to its parent joint's bone and to
    both bones' rest, in world axes (P_rest P_pose^-1 M_pose M_rest^-1), then its twist about the joint's
    axis. `joints`: joint -> {"bone": its bone, "parent": the parent joint's bone or None, "axis": the
    joint's unit axis in the robot's frame at zero}."""
    scene = bpy.context.scene
    out: dict[str, list[float]] = {j: [] for j in joints}
    world = rig.matrix_world.to_3x3()
    for fr in times:
        whole = math.floor(fr)
        scene.frame_set(int(whole), subframe=fr - whole)
        ev = rig.evaluated_get(bpy.context.evaluated_depsgraph_get())
        for joint, info in joints.items():
            pb = ev.pose.bones[info["bone"]]
            m_pose, m_rest = pb.matrix.to_3x3(), pb.bone.matrix_local.to_3x3()
            if info["parent"] is None:
                p_pose = p_rest = Matrix.Identity(3)
            else:
                parent = ev.pose.bones[info["parent"]]
                p_pose, p_rest = parent.matrix.to_3x3(), parent.bone.matrix_local.to_3x3()
            d = world @ p_rest @ p_pose.inverted() @ m_pose @ m_rest.inverted() @ world.inverted()
            q = d.to_quaternion()
            a = info["axis"]
            angle = 2.0 * math.atan2(q.x * a[0] + q.y * a[1] + q.z * a[2], q.w)
            out[joint].append((angle + math.pi) % (2 * math.pi) - math.pi)
    return out


def operator_error(op, **kw) -> str | None:
    """Run a Nutty operator; the message of the ERROR it reports (Blender raises it), None if it ran."""
    try:
        op(**kw)
    except RuntimeError as exc:
        return str(exc)
    return None


namespace = {
    "bpy": bpy,
    "nutty_blender": nutty_blender,
    "reset_scene": reset_scene,
    "key": key,
    "joint_angles": joint_angles,
    "operator_error": operator_error,
    "Matrix": Matrix,
    "math": math,
    "json": json,
}
protocol.write(json.dumps({"ok": True, "result": {"blender": bpy.app.version_string}}) + "\n")
for line in sys.stdin:
    request = json.loads(line)
    namespace["args"] = request.get("args", {})
    namespace.pop("result", None)
    try:
        exec(request["code"], namespace)
        reply = {"ok": True, "result": namespace.get("result")}
    except Exception:
        reply = {"ok": False, "error": traceback.format_exc()}
    protocol.write(json.dumps(reply) + "\n")
