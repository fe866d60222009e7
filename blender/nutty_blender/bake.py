"""Export what the viewport shows, not only the active action's keys: when a rig's motion comes from
anything else (NLA strips, constraints other than the rig's own limits, IK, drivers other than the rig's
own, F-curve modifiers), the export bakes the evaluated pose.

For each frame of the scene's range the scene is set to that frame and each control bone's evaluated
local Y angle (rad: its rotation about the joint axis relative to its parent bone, after every
constraint) and each symbolic DoF property are read. Each DoF whose value moves, or that any action
animates, becomes per-frame keys smooth at the engine's rate: cubic Hermite pieces (Bezier keys with
free handles a third of a frame long) whose slopes are central finite differences of the samples
(second-order one-sided at the ends), so the curve and its velocity are continuous between frames.
Linear per-frame keys would jump in velocity at every frame: acceleration spikes at the engine's 100 Hz.
Colour and face properties only an NLA strip or a driver animates are baked too (`_display_keys`).
"""

from __future__ import annotations

import math
from typing import Any

from .robot import RigPlan

LIMITS_CONSTRAINT = "Nutty limits"  # the rig's own Limit Rotation (rig.py)
ROUND = 9
MOVES = 1e-5  # a DoF whose baked values span more moves (rad: far above float32 pose-matrix noise)


def action_paths(action: Any) -> set[tuple[str, int]]:
    """(data path, index) of every F-curve of `action` (every slot of a layered action)."""
    if action is None:
        return set()
    if not getattr(action, "is_action_layered", False) and hasattr(action, "fcurves"):  # Blender < 4.4
        return {(fc.data_path, fc.array_index) for fc in action.fcurves}
    return {
        (fc.data_path, fc.array_index)
        for layer in action.layers
        for strip in layer.strips
        for bag in strip.channelbags
        for fc in bag.fcurves
    }


def _own_driver(rig_ob: Any, fc: Any) -> bool:
    """A driver the rig built itself: the Y rotation of a bone of the rig that is no DoF's control bone
    (a hidden drive bone, or a joint only symbolic DoFs drive)."""
    if not fc.data_path.endswith("].rotation_euler") or fc.array_index != 1:
        return False
    try:
        owner = rig_ob.path_resolve(fc.data_path.rsplit(".", 1)[0])
    except ValueError:  # a path to nothing (a removed bone): not the rig's
        return False
    return "nutty_joint" in owner and "nutty_dof" not in owner


def bake_reasons(rig_ob: Any, curves: list[Any]) -> list[str]:
    """Why the active action's keys are not the whole motion ([] when they are): in words for a note."""
    reasons = []
    ad = rig_ob.animation_data
    if ad is not None and any(not t.mute and len(t.strips) for t in ad.nla_tracks):
        reasons.append("NLA strips")
    if ad is not None and any(not _own_driver(rig_ob, fc) and not fc.mute for fc in ad.drivers):
        reasons.append("drivers")
    kinds = {
        c.type
        for pb in rig_ob.pose.bones
        for c in pb.constraints
        if c.enabled and c.influence > 0.0 and c.name != LIMITS_CONSTRAINT
    }
    if "IK" in kinds:
        reasons.append("IK")
    if kinds - {"IK"}:
        reasons.append(f"constraints ({', '.join(sorted(k.lower() for k in kinds - {'IK'}))})")
    if any(not fc.mute and any(not m.mute for m in fc.modifiers) for fc in curves):
        reasons.append("F-curve modifiers")
    return reasons


def animated_paths(rig_ob: Any) -> set[tuple[str, int]]:
    """Every (data path, index) any action of the rig animates (the active one, NLA strips) or a driver
    other than the rig's own sets."""
    ad = rig_ob.animation_data
    if ad is None:
        return set()
    paths = action_paths(ad.action)
    for track in ad.nla_tracks:
        for strip in track.strips:
            paths |= action_paths(strip.action)
    paths |= {(fc.data_path, fc.array_index) for fc in ad.drivers if not _own_driver(rig_ob, fc)}
    return paths


def local_y_angle(pb: Any) -> float:
    """The evaluated pose bone's rotation about its own Y axis relative to its parent bone and to its
    rest (rad, in (-pi, pi]): the joint angle, constraints and IK included (any swing is left out)."""
    rest = pb.bone.matrix_local
    if pb.parent is not None:
        local = (pb.parent.bone.matrix_local.inverted() @ rest).inverted() @ pb.parent.matrix.inverted()
        local = local @ pb.matrix
    else:
        local = rest.inverted() @ pb.matrix
    q = local.to_quaternion()
    return (2.0 * math.atan2(q.y, q.w) + math.pi) % (2 * math.pi) - math.pi


def _unwrap(values: list[float]) -> list[float]:
    """Angles made continuous across +-pi (a continuous joint turning on)."""
    out = values[:1]
    for v in values[1:]:
        out.append(v + 2 * math.pi * round((out[-1] - v) / (2 * math.pi)))
    return out


def sample_pose(
    rig_ob: Any, bones: dict[str, str], props: list[str], frames: list[int], scene: Any, context: Any
) -> dict[str, list[Any]]:
    """DoF -> its evaluated value at each frame: `bones` (DoF -> control bone) by their local Y angle
    (rad), `props` (DoF properties) by the evaluated property (a float, or a colour's [r, g, b]). The
    scene ends at the frame it was on."""
    current = scene.frame_current
    out: dict[str, list[Any]] = {dof: [] for dof in [*bones, *props]}
    try:
        for f in frames:
            scene.frame_set(f)
            ev = rig_ob.evaluated_get(context.evaluated_depsgraph_get())
            for dof, bone in bones.items():
                out[dof].append(local_y_angle(ev.pose.bones[bone]))
            for name in props:
                value = ev.get(name, rig_ob.get(name, 0.0))
                out[name].append([float(c) for c in value] if hasattr(value, "__len__") else float(value))
    finally:
        scene.frame_set(current)
    return {dof: _unwrap(v) if dof in bones else v for dof, v in out.items()}


def hermite_keys(values: list[float], frames: list[int], fps: float) -> list[dict[str, Any]]:
    """Clip keys through `values` at consecutive `frames` (t = (frame - frames[0]) / fps s): Bezier
    pieces with free handles of a third of a frame, slopes from central differences (per frame;
    second-order one-sided at the ends)."""
    n = len(values)
    keys = []
    for k, v in enumerate(values):
        if n == 1:
            slope = 0.0
        elif n == 2:
            slope = values[1] - values[0]
        elif k == 0:  # second-order one-sided differences: a motion starting or ending at rest stays so
            slope = (-3.0 * values[0] + 4.0 * values[1] - values[2]) / 2.0
        elif k == n - 1:
            slope = (3.0 * values[-1] - 4.0 * values[-2] + values[-3]) / 2.0
        else:
            slope = (values[k + 1] - values[k - 1]) / 2.0
        key: dict[str, Any] = {"t": round((frames[k] - frames[0]) / fps, ROUND), "v": round(v, ROUND)}
        third = round(1.0 / 3.0 / fps, ROUND)
        if k > 0:
            key["left_type"], key["left"] = "free", [-third, round(-slope / 3.0, ROUND)]
        if k < n - 1:
            key.update(interp="bezier", right_type="free", right=[third, round(slope / 3.0, ROUND)])
        else:
            key["interp"] = "linear"
        keys.append(key)
    return keys


def _display_keys(prop: Any, values: list[Any], frames: list[int], fps: float) -> list[dict[str, Any]]:
    """A colour or enum property's per-frame values as clip keys: an enum's option at each change
    (constant), a colour at every frame where it differs from a neighbour (linear between)."""
    keys: list[dict[str, Any]] = []
    for k, v in enumerate(values):
        t = round((frames[k] - frames[0]) / fps, ROUND)
        if prop.kind == "enum":
            option = prop.options[min(max(round(v), 0), len(prop.options) - 1)]
            if not keys or keys[-1]["v"] != option:
                keys.append({"t": t, "v": option, "interp": "constant"})
        elif k in (0, len(values) - 1) or v != values[k - 1] or v != values[k + 1]:
            keys.append({"t": t, "v": [round(min(max(c, 0.0), 1.0), ROUND) for c in v], "interp": "linear"})
    return keys


def baked_tracks(
    rig_ob: Any, plan: RigPlan, bones: dict[str, str], scene: Any, context: Any, fps: float, keyed: set[str]
) -> dict[str, list[dict[str, Any]]]:
    """The baked tracks (see the module doc): DoF -> clip keys, for the continuous DoFs and the colour
    and face properties an NLA strip or driver animates (`keyed`: the DoFs the active action's keys
    export already). `bones`: DoF -> the rig's control bone (its actual name)."""
    from .rig import dof_paths  # (rig imports bpy: only when baking in Blender)

    frames = list(range(int(scene.frame_start), int(scene.frame_end) + 1))
    animated = animated_paths(rig_ob)
    display = {
        p.name: p
        for p in plan.props
        if p.kind in ("colour", "enum")
        and p.name not in keyed
        and any(a[0] == f'["{p.name}"]' for a in animated)
    }
    props = [p.name for p in plan.props if p.kind == "float"] + list(display)
    samples = sample_pose(rig_ob, bones, props, frames, scene, context)
    paths = dof_paths(rig_ob, plan)
    animated_dofs = {dof for path, dof in paths.items() if path in animated}
    tracks = {}
    for dof, values in samples.items():
        if dof in display:
            tracks[dof] = _display_keys(display[dof], values, frames, fps)
        elif dof in animated_dofs or max(values) - min(values) > MOVES:
            tracks[dof] = hermite_keys(values, frames, fps)
    return tracks
