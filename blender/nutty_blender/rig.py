"""Building the armature of a rig plan (robot.py) in Blender: bones, locks, Limit Rotation, drivers,
custom properties, and the robot's meshes parented to their bones. Also where a rig's animation is
(`fcurves`, which works with Blender 4.2's actions and with 4.4+/5.x slotted actions).
"""

from __future__ import annotations

import json
from typing import Any

import bpy
from mathutils import Matrix, Vector

from .robot import RigPlan, plan_rig

ROBOT_KEY = "_nutty_robot"  # the robot's description (JSON) on the armature object; "_": hidden in the UI
GHOST_KEY = "_nutty_ghost_of"  # on a ghost armature: the name of the rig it shadows
ROTATION = "rotation_euler"
DOF_INDEX = 1  # the bone's local Y: the joint angle
ROTATION_MODE = "YXZ"  # Y first: a whole joint range (beyond +-90 deg) is one Euler channel
CONTROLS, DRIVERS = "Nutty controls", "Nutty drivers"


def robot_of(ob: Any) -> dict[str, Any] | None:
    """The robot description a rig was built from, or None for any other object."""
    raw = ob.get(ROBOT_KEY) if ob is not None and ob.type == "ARMATURE" else None
    return json.loads(raw) if isinstance(raw, str) else None


def plan_of(ob: Any) -> RigPlan:
    return plan_rig(robot_of(ob))


def find_rig(context: Any) -> Any:
    """The rig to work on: the active object if it is a Nutty rig (not a ghost), else the scene's only one."""
    ob = context.active_object
    if robot_of(ob) is not None and GHOST_KEY not in ob:
        return ob
    rigs = [o for o in context.scene.objects if robot_of(o) is not None and GHOST_KEY not in o]
    return rigs[0] if len(rigs) == 1 else None


def fcurves(ob: Any) -> list[Any]:
    """The F-curves of `ob`'s action (the slot assigned to it on Blender 4.4+), [] without one."""
    ad = ob.animation_data
    if ad is None or ad.action is None:
        return []
    action = ad.action
    if hasattr(action, "fcurves") and not getattr(
        action, "is_action_layered", False
    ):  # Blender < 4.4 / legacy
        return list(action.fcurves)
    from bpy_extras import anim_utils  # (Blender 4.4+ only: slotted actions)

    bag = anim_utils.animdata_get_channelbag_for_assigned_slot(ad)
    return list(bag.fcurves) if bag is not None else []


def _bone_length(plan: RigPlan) -> float:
    """A bone length that suits the robot's size (m): 1/8 of its joints' extent, within 1-15 cm."""
    heads = [b.head for b in plan.bones] or [(0.0, 0.0, 0.0)]
    extent = max(max(h[i] for h in heads) - min(h[i] for h in heads) for i in range(3))
    return min(max(extent / 8.0, 0.01), 0.15)


def _props(ob: Any, plan: RigPlan) -> None:
    for p in plan.props:
        ob[p.name] = p.default
        ui = ob.id_properties_ui(p.name)
        kw: dict[str, Any] = {"description": p.description}
        if p.min is not None:
            kw.update(min=p.min, soft_min=p.min)
        if p.max is not None:
            kw.update(max=p.max, soft_max=p.max)
        if p.kind == "colour":
            kw["subtype"] = "COLOR"
        ui.update(**kw)


def _edit_bones(ob: Any, plan: RigPlan) -> None:
    arm = ob.data
    length = _bone_length(plan)
    bpy.ops.object.mode_set(mode="EDIT")
    for b in plan.bones:
        eb = arm.edit_bones.new(b.name)
        head = Vector(b.head)
        # a drive bone is shorter than its control bone, so both can be picked when shown
        eb.head, eb.tail = head, head + Vector(b.axis) * (length * (0.6 if b.hidden else 1.0))
        eb.align_roll(Vector(b.roll_ref))
        eb.use_deform = False
        if b.parent is not None:
            eb.parent = arm.edit_bones[b.parent]
            eb.use_connect = False
    bpy.ops.object.mode_set(mode="OBJECT")


def _pose_bones(ob: Any, plan: RigPlan) -> None:
    arm = ob.data
    controls = arm.collections.new(CONTROLS)
    drivers = arm.collections.new(DRIVERS)
    drivers.is_visible = False
    for b in plan.bones:
        pb = ob.pose.bones[b.name]
        pb.rotation_mode = ROTATION_MODE
        pb.lock_location = pb.lock_scale = (True, True, True)
        pb.lock_rotation = (True, b.dof is None, True)  # only a control bone's Y turns by hand
        pb.lock_rotation_w = True
        pb.lock_ik_x = pb.lock_ik_z = True  # IK turns a joint about its axis only, within its limits
        pb.lock_ik_y = b.dof is None
        if b.limits is not None:
            pb.use_ik_limit_y = True
            pb.ik_min_y, pb.ik_max_y = min(b.limits[0], 0.0), max(b.limits[1], 0.0)  # (IK's own ranges)
        (drivers if b.hidden else controls).assign(pb.bone)
        pb.bone.hide = b.hidden
        pb["nutty_joint"] = b.joint
        if b.dof is not None:
            pb["nutty_dof"] = b.dof
            pb.rotation_euler[DOF_INDEX] = b.rest
        if b.limits is not None:
            c = pb.constraints.new("LIMIT_ROTATION")
            c.name = "Nutty limits"
            c.owner_space = "LOCAL"
            c.euler_order = ROTATION_MODE
            c.use_limit_y = True
            c.min_y, c.max_y = b.limits
            c.use_transform_limit = True  # the rotate tool stops at the limit too
        if b.expression is not None:
            _driver(ob, pb, b.expression, b.variables)


def _driver(ob: Any, pb: Any, expression: str, variables: dict[str, tuple[str, str]]) -> None:
    fc = pb.driver_add(ROTATION, DOF_INDEX)
    drv = fc.driver
    drv.type = "SCRIPTED"
    for name, (kind, target) in variables.items():
        var = drv.variables.new()
        var.name = name
        t = var.targets[0]
        if kind == "prop":
            var.type = "SINGLE_PROP"
            t.id_type = "OBJECT"
            t.id = ob
            t.data_path = f'["{target}"]'
        else:  # the control bone's angle after its Limit Rotation ("transform space")
            var.type = "TRANSFORMS"
            t.id = ob
            t.bone_target = target
            t.transform_type = "ROT_Y"
            t.transform_space = "TRANSFORM_SPACE"
            t.rotation_mode = "AUTO"
    drv.expression = expression  # min/max/+/*: Blender's simple expressions, no Python auto-run needed


def parent_to_bone(mesh_ob: Any, rig: Any, bone: str | None) -> None:
    """Parent `mesh_ob` to `bone` of `rig` (None: to the rig itself), keeping where it is at rest."""
    world = mesh_ob.matrix_world.copy()
    mesh_ob.parent = rig
    if bone is None:
        mesh_ob.parent_type = "OBJECT"
        mesh_ob.matrix_parent_inverse = rig.matrix_world.inverted()
    else:
        b = rig.data.bones[bone]
        mesh_ob.parent_type = "BONE"
        mesh_ob.parent_bone = bone
        # a bone child hangs from the bone's tail; this inverse puts it back where it was at rest
        tail = rig.matrix_world @ b.matrix_local @ Matrix.Translation((0.0, b.length, 0.0))
        mesh_ob.matrix_parent_inverse = tail.inverted()
    mesh_ob.matrix_basis = world


def import_meshes(glb_path: str, collection: Any) -> list[Any]:
    """The GLB's mesh objects (scene.glb), moved into `collection`."""
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=glb_path)
    new = [o for o in bpy.data.objects if o not in before]
    for o in new:
        for c in list(o.users_collection):
            c.objects.unlink(o)
        collection.objects.link(o)
    return [o for o in new if o.type == "MESH"]


def link_of(mesh_ob: Any) -> str:
    """The URDF link a scene.glb mesh belongs to (its mesh's `nutty_link` extra, else its name)."""
    link = mesh_ob.data.get("nutty_link") if mesh_ob.data is not None else None
    return str(link) if link else mesh_ob.name.rsplit("|", 1)[0]


def build(context: Any, robot: dict[str, Any], plan: RigPlan, name: str, collection: Any) -> Any:
    """A new armature object `name` for `plan`, linked into `collection`, in its rest pose (each
    control bone at its DoF's rest value, each property at its rest)."""
    arm = bpy.data.armatures.new(name)
    arm.display_type = "STICK"
    ob = bpy.data.objects.new(name, arm)
    collection.objects.link(ob)
    ob.show_in_front = True  # the bones stay visible inside the robot's shell
    ob[ROBOT_KEY] = json.dumps(robot)
    _props(ob, plan)
    view_layer = context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = ob
    try:
        _edit_bones(ob, plan)
    finally:
        view_layer.objects.active = (
            previous if previous is not None and previous.name in view_layer.objects else ob
        )
    _pose_bones(ob, plan)
    return ob


def bone_path(bone: str) -> str:
    """The F-curve data path of a bone's rotation (the name escaped as Blender writes it)."""
    return f'pose.bones["{bpy.utils.escape_identifier(bone)}"].{ROTATION}'


def control_bones(ob: Any, plan: RigPlan) -> dict[str, str]:
    """DoF -> the name of its control bone in `ob` as it is now: found by the bone's `nutty_dof`
    property, so a bone renamed in Blender keeps its DoF. NuttyError-free: a DoF whose bone is gone is
    left out (`missing_dofs` names them)."""
    out = {}
    for pb in ob.pose.bones:
        dof = pb.get("nutty_dof")
        if isinstance(dof, str) and dof in plan.dof_bones and dof not in out:
            out[dof] = pb.name
    return out


def missing_dofs(ob: Any, plan: RigPlan) -> list[str]:
    """The DoFs of the plan without a control bone in `ob` (deleted, or their `nutty_dof` removed)."""
    found = control_bones(ob, plan)
    return [dof for dof in plan.dof_bones if dof not in found]


def dof_paths(ob: Any, plan: RigPlan) -> dict[tuple[str, int], str]:
    """(F-curve data path, array index) -> continuous DoF, for the rig's keyable DoFs: each control
    bone's rotation by its actual name, and (orphaned F-curves, e.g. an action made before the bone was
    renamed) the plan's original bone name of a DoF when no bone has that name any more."""
    out = {}
    names = {pb.name for pb in ob.pose.bones}
    for dof, bone in plan.dof_bones.items():
        if bone not in names:
            out[(bone_path(bone), DOF_INDEX)] = dof
    for dof, bone in control_bones(ob, plan).items():
        out[(bone_path(bone), DOF_INDEX)] = dof
    for p in plan.props:
        if p.kind == "float":
            out[(f'["{p.name}"]', 0)] = p.name
    return out


def reconnect(ob: Any, plan: RigPlan, renamed: dict[str, str]) -> list[str]:
    """Point orphaned F-curves of `ob`'s action (their bone is gone) at the bone of their DoF: a path
    naming a bone of an earlier rig (`renamed`: old bone name -> its DoF) or a DoF's original bone name.
    Returns one note per F-curve reconnected."""
    names = {pb.name for pb in ob.pose.bones}
    bones = control_bones(ob, plan)
    original = {bone: dof for dof, bone in plan.dof_bones.items()}
    notes = []
    for fc in fcurves(ob):
        prefix, suffix = 'pose.bones["', f'"].{ROTATION}'
        path = fc.data_path
        if not (path.startswith(prefix) and path.endswith(suffix)) or fc.array_index != DOF_INDEX:
            continue
        old = bpy.utils.unescape_identifier(path[len(prefix) : -len(suffix)])
        dof = renamed.get(old) or original.get(old)
        if old in names or dof not in bones or bones[dof] == old:
            continue
        if any(f.data_path == bone_path(bones[dof]) and f.array_index == DOF_INDEX for f in fcurves(ob)):
            continue  # the bone has its own curve: leave the orphan alone (the export notes it)
        fc.data_path = bone_path(bones[dof])
        notes.append(f"reconnected the keys of bone '{old}' to '{bones[dof]}' (DoF '{dof}')")
    return notes
