"""Nutty > Load robot: fetch the running robot (GET /api/robot, /api/robot/scene.glb) and rig it."""

from __future__ import annotations

import os
import tempfile
from typing import Any

import bpy

from . import display, rig
from .client import Client, NuttyError
from .robot import plan_rig

COLLECTION = "Nutty"


def _collection(context: Any) -> Any:
    col = bpy.data.collections.get(COLLECTION)
    if col is None:
        col = bpy.data.collections.new(COLLECTION)
    if col.name not in context.scene.collection.children:
        context.scene.collection.children.link(col)
    return col


def remove_rig(ob: Any) -> None:
    """Delete an armature and the objects parented to it (its meshes), and their unused meshes."""
    meshes = [c.data for c in ob.children if c.type == "MESH"]
    for child in list(ob.children):
        bpy.data.objects.remove(child, do_unlink=True)
    arm = ob.data
    bpy.data.objects.remove(ob, do_unlink=True)
    if arm.users == 0:
        bpy.data.armatures.remove(arm)
    for mesh in meshes:
        if mesh.users == 0:
            bpy.data.meshes.remove(mesh)


def _fetch_meshes(client: Client, collection: Any, warnings: list[str]) -> list[Any]:
    try:
        glb = client.request("GET", "/api/robot/scene.glb")
    except NuttyError as exc:  # a robot without visuals is still rigged, with bones only
        warnings.append(f"no meshes: {exc}")
        return []
    fd, path = tempfile.mkstemp(suffix=".glb", prefix="nutty-")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(glb)
        return rig.import_meshes(path, collection)
    finally:
        os.unlink(path)


def load_robot(context: Any, client: Client) -> tuple[Any, list[str]]:
    """Build the rig of the server's robot (replacing an earlier rig of it, whose action it keeps) and
    return it with warnings for the report. NuttyError / RigError say why it cannot."""
    robot = client.get("/api/robot")
    if not isinstance(robot, dict) or "dofs" not in robot:
        raise NuttyError(f"{client.url}/api/robot is not a robot description: is this a nutty serve?")
    plan = plan_rig(robot)
    warnings = list(plan.warnings)
    name = plan.robot
    action = None
    renamed: dict[str, str] = {}  # a bone of the old rig -> its DoF (its keys follow the DoF)
    for old in [o for o in context.scene.objects if rig.robot_of(o) is not None]:
        if old.name == name or old.get(rig.GHOST_KEY) == name:
            if old.get(rig.GHOST_KEY) is None and old.animation_data is not None:
                action = old.animation_data.action
                renamed = {pb.name: pb["nutty_dof"] for pb in old.pose.bones if "nutty_dof" in pb}
            remove_rig(old)
    collection = _collection(context)
    ob = rig.build(context, robot, plan, name, collection)
    meshes = _fetch_meshes(client, collection, warnings)
    for mesh in meshes:
        link = rig.link_of(mesh)
        if link not in plan.link_bones:
            warnings.append(
                f"mesh '{mesh.name}' belongs to link '{link}', which no joint moves: it follows the base"
            )
        rig.parent_to_bone(mesh, ob, plan.link_bones.get(link))
    display.drive_display(ob, robot, meshes)  # LED colours and the face show in the viewport
    if action is not None:
        ob.animation_data_create().action = action
        slots = getattr(action, "slots", None)
        if slots and getattr(ob.animation_data, "action_slot", None) is None:
            ob.animation_data.action_slot = slots[0]
        warnings += rig.reconnect(ob, plan, renamed)
    for o in context.view_layer.objects:
        o.select_set(False)
    ob.select_set(True)
    context.view_layer.objects.active = ob
    return ob, warnings
