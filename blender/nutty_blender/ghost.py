"""Nutty > Ghost: the exported clip through the motion filter (POST /api/filter, a named preset or the
running program's stage 2, at the engine's rate: see preview.py), baked onto a translucent copy of the
rig (`<rig>.ghost`: one linear key per frame, exactly the server's values) standing beside it (or on
it), so the authored and the filtered motion can be scrubbed side by side.
"""

from __future__ import annotations

from typing import Any

import bpy
from mathutils import Matrix, Vector

from . import clip, display, preview, rig
from .client import Client
from .load import COLLECTION, remove_rig

GHOST_MATERIAL = "Nutty ghost"
GHOST_RGBA = (0.55, 0.8, 1.0, 0.3)


def ghost_of(scene: Any, rig_ob: Any) -> Any:
    return next((o for o in scene.objects if o.get(rig.GHOST_KEY) == rig_ob.name), None)


def _material() -> Any:
    mat = bpy.data.materials.get(GHOST_MATERIAL)
    if mat is None:
        mat = bpy.data.materials.new(GHOST_MATERIAL)
        mat.diffuse_color = GHOST_RGBA  # the viewport's (and Workbench's) colour, translucent
        if hasattr(mat, "surface_render_method"):  # EEVEE (Blender 4.2+)
            mat.surface_render_method = "BLENDED"
        mat.use_nodes = True
        bsdf = mat.node_tree.nodes.get("Principled BSDF")
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = (*GHOST_RGBA[:3], 1.0)
            bsdf.inputs["Alpha"].default_value = GHOST_RGBA[3]
    return mat


def _copy_meshes(rig_ob: Any, ghost: Any, collection: Any) -> None:
    """The rig's meshes again (sharing their mesh data), on the ghost's bones, in the ghost material."""
    mat = _material()
    for child in rig_ob.children:
        if child.type != "MESH":
            continue
        c = child.copy()
        display.clear_drivers(c)  # (the copy's drivers would read the rig's lights, not the ghost's)
        collection.objects.link(c)
        c.parent = (
            ghost  # (setting the parent resets how it hangs: restore it, so it sits where the child does)
        )
        c.parent_type, c.parent_bone = child.parent_type, child.parent_bone
        c.matrix_parent_inverse = child.matrix_parent_inverse.copy()
        c.matrix_basis = child.matrix_basis.copy()
        c.hide_select = True  # clicks go to the authored rig
        for slot in c.material_slots:
            slot.link = "OBJECT"
            slot.material = mat
        c.color = GHOST_RGBA


def bake(ghost: Any, plan: Any, timing: clip.Timing, tracks: dict[str, list[float]]) -> None:
    """One linear key per frame of the scene's range for each DoF in `tracks` (values per frame; DoFs
    the ghost has no channel for are left out)."""
    paths = {dof: path for path, dof in rig.dof_paths(ghost, plan).items()}
    for dof, values in tracks.items():
        if dof not in paths or not values:
            continue
        data_path, index = paths[dof]
        frames = timing.frames[: len(values)]  # value k at the scene's start frame + k
        values = list(values)[: len(frames)]
        scalar = data_path.startswith('["')  # a DoF property (index -1: the whole, one-value property)
        ghost.keyframe_insert(
            data_path, index=-1 if scalar else index, frame=frames[0]
        )  # action, slot, curve
        fc = next(f for f in rig.fcurves(ghost) if f.data_path == data_path and f.array_index == index)
        fc.keyframe_points.clear()
        fc.keyframe_points.add(len(frames))
        fc.keyframe_points.foreach_set("co", [x for f, v in zip(frames, values) for x in (f, v)])
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"
        fc.update()


def beside(rig_ob: Any, offset: float) -> Matrix:
    """Where the ghost stands: `offset` m along the rig's +Y (the robot's left); a negative offset means
    one robot width (its meshes' extent along Y, plus a fifth), so the two never overlap."""
    if offset < 0:
        ys = [
            (c.matrix_world @ Vector(corner)).y
            for c in rig_ob.children
            if c.type == "MESH"
            for corner in c.bound_box
        ]
        offset = 1.2 * (max(ys) - min(ys)) if ys else 0.5
    return rig_ob.matrix_world @ Matrix.Translation((0.0, offset, 0.0))


def make_ghost(
    context: Any, client: Client, rig_ob: Any, preset: str | None, offset: float = -1.0
) -> tuple[Any, dict[str, Any]]:
    """Build (or rebuild) the ghost of `rig_ob` `offset` m beside it (see `beside`); `preset` None: the
    running program's stage-2 filter. Returns the ghost, the server's answer and the export's notes."""
    plan = rig.plan_of(rig_ob)
    timing = clip.Timing.of(context.scene)
    result, notes = preview.post(
        client, "/api/filter", context.scene, rig_ob, plan, {"preset": preset} if preset else None
    )
    old = ghost_of(context.scene, rig_ob)
    if old is not None:
        remove_rig(old)
    collection = bpy.data.collections.get(COLLECTION) or rig_ob.users_collection[0]
    ghost = rig.build(context, rig.robot_of(rig_ob), plan, f"{rig_ob.name}.ghost", collection)
    ghost[rig.GHOST_KEY] = rig_ob.name
    ghost.matrix_world = beside(rig_ob, offset)
    ghost.data.display_type = "WIRE"
    ghost.show_in_front = False
    _copy_meshes(rig_ob, ghost, collection)
    for dof, bone in rig.control_bones(rig_ob, plan).items():  # DoFs without keys keep the rig's pose
        ghost.pose.bones[plan.dof_bones[dof]].rotation_euler = rig_ob.pose.bones[bone].rotation_euler
    for p in plan.props:
        ghost[p.name] = rig_ob.get(p.name, p.default)
    ghost.animation_data_create().action = bpy.data.actions.new(f"{rig_ob.name}.ghost")
    bake(ghost, plan, timing, result["tracks"])
    return ghost, result, notes
