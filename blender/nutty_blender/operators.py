"""The Nutty menu's operators: thin wrappers over load, clip, limits, ghost and live, which report every
expected failure (server down, robot the add-on cannot rig, an action without keys, ...) as one
clear line in Blender's report. An unexpected error is reported in one line too, its traceback only
logged (Blender's system console) for a bug report.
"""

# (no `from __future__ import annotations`: Blender reads the property annotations as objects)
import json
import logging
import re
from typing import Any

import bpy
from bpy.props import EnumProperty, StringProperty

from . import clip, clip_import, ghost, limits, live, load, rig
from .client import Client, NuttyError
from .robot import RigError
from .settings import PRESETS

log = logging.getLogger(__name__)

EXPECTED = (NuttyError, RigError, clip.ExportError)
CLIP_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_\-.]{0,79}$")  # as backend/engine/library.py names assets


def client_of(context: Any) -> Client:
    """The server of the Nutty panel. A server on another machine needs Blender's *Allow Online Access*
    (the extension rule); one on this machine (loopback) does not."""
    client = Client(context.scene.nutty.server_url, context.window_manager.nutty_token)
    if not client.loopback and not getattr(bpy.app, "online_access", True):
        raise NuttyError(
            f"{client.url} is on another machine and Blender's online access is off: allow it in "
            f"Preferences > System > Network, or run nutty serve on this machine"
        )
    return client


def rig_of(context: Any) -> Any:
    ob = rig.find_rig(context)
    if ob is None:
        raise NuttyError("no Nutty rig to work on: use Nutty > Load robot first (or select the rig)")
    return ob


class _NuttyOperator(bpy.types.Operator):
    """Base: `run(context)` does the work and returns a one-line INFO report (or None)."""

    bl_options = {"REGISTER"}

    def run(self, context: Any) -> str | None:
        raise NotImplementedError

    def execute(self, context: Any) -> set[str]:
        try:
            message = self.run(context)
        except EXPECTED as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except Exception as exc:  # a bug: say so in one line, keep the traceback for the console
            log.exception("Nutty operator %s failed", self.bl_idname)
            self.report(
                {"ERROR"}, f"Nutty: unexpected {type(exc).__name__}: {exc} (details in the system console)"
            )
            return {"CANCELLED"}
        if message:
            self.report({"INFO"}, message)
        return {"FINISHED"}

    def warn(self, notes: list[str]) -> None:
        for note in notes:
            self.report({"WARNING"}, note)


class NUTTY_OT_load_robot(_NuttyOperator):
    """Fetch the robot of the running nutty serve and rig it: one bone per joint, limits, symbolic DoFs
    as properties driving their joints, the robot's meshes on their bones"""

    bl_idname = "nutty.load_robot"
    bl_label = "Load robot"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context: Any) -> str:
        ob, warnings = load.load_robot(context, client_of(context))
        self.warn(warnings)
        plan = rig.plan_of(ob)
        return f"loaded '{ob.name}': {len(plan.dof_bones)} DoF bones, {len(plan.props)} properties"


class NUTTY_OT_export_clip(_NuttyOperator):
    """Export the rig's action as a nutty-clip/1 clip: to the robot's library on the server, or a file"""

    bl_idname = "nutty.export_clip"
    bl_label = "Export clip"
    bl_options = {"REGISTER", "UNDO"}  # (a face or sound key is made constant, as the engine plays it)

    name: StringProperty(
        name="Clip name", description="default: the Nutty panel's clip name, else the action's"
    )
    target: EnumProperty(
        name="Export to",
        items=[("PANEL", "As in the panel", ""), ("SERVER", "Server", ""), ("FILE", "File", "")],
        default="PANEL",
    )
    filepath: StringProperty(name="File", subtype="FILE_PATH", description="default: the Nutty panel's file")

    def run(self, context: Any) -> str:
        settings = context.scene.nutty
        ob = rig_of(context)
        ad = ob.animation_data
        strips = [s.action for t in ad.nla_tracks for s in t.strips if s.action] if ad else []
        action = ad.action if ad and ad.action else next(iter(strips), None)  # (NLA only: its first)
        name = (self.name or settings.clip_name or (action.name if action else ob.name)).strip()
        doc, notes = clip.export_clip(ob, rig.plan_of(ob), context.scene, name)  # (no keys: said first)
        if not CLIP_NAME.match(name):  # the server's library rule, checked here so the name is never a path
            raise clip.ExportError(
                f"invalid clip name {name!r}: use letters, digits, '_', '-' or '.' "
                f"(at most 80 characters, not starting with '-' or '.')"
            )
        self.warn(notes)
        target = settings.export_target if self.target == "PANEL" else self.target
        if target == "FILE":
            path = bpy.path.abspath(self.filepath or settings.export_path)
            try:
                with open(path, "w", encoding="utf-8") as fh:
                    json.dump(doc, fh, indent=1)
            except OSError as exc:
                raise clip.ExportError(f"cannot write '{path}': {exc.strerror}") from None
            return f"wrote clip '{name}' ({len(doc['tracks'])} tracks, {doc['duration']:g} s) to {path}"
        client_of(context).put(f"/api/clips/{name}", doc)
        return f"saved clip '{name}' ({len(doc['tracks'])} tracks, {doc['duration']:g} s) on {settings.server_url}"


class NUTTY_OT_import_clip(_NuttyOperator):
    """Import a clip of the robot's library as a new action on the rig: keys, interpolations, easings and
    handles as the engine plays them, anchors and events as timeline markers"""

    bl_idname = "nutty.import_clip"
    bl_label = "Import clip"
    bl_options = {"REGISTER", "UNDO"}

    name: StringProperty(name="Clip name", description="default: the Nutty panel's clip name")

    def run(self, context: Any) -> str:
        ob = rig_of(context)
        name = (self.name or context.scene.nutty.clip_name).strip()
        action, notes = clip_import.import_clip(context, client_of(context), ob, name)
        self.warn(notes)
        scene = context.scene
        return (
            f"imported clip '{name}' as action '{action.name}' (frames {scene.frame_start}-{scene.frame_end})"
        )


class NUTTY_OT_check_limits(_NuttyOperator):
    """Check the action against the robot's limits (the trajectory-helper): offending frame ranges as
    markers, coloured bones and curves, and a list in the Nutty panel"""

    bl_idname = "nutty.check_limits"
    bl_label = "Check limits"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context: Any) -> str:
        result, notes = limits.check_limits(context, client_of(context), rig_of(context))
        self.warn(notes)
        s = context.scene.nutty
        kinds = sorted({r["kind"] for r in result["ranges"]})
        rate = result.get("engine_rate")
        where = f" at the engine's {rate:g} Hz" if rate else ""
        return (
            f"Nutty limits{where}: {s.check_summary}"
            + (f" ({', '.join(kinds)})" if kinds else "")
            + (f"; {s.suggestion}" if s.suggestion else "")
            + (f"; {s.physics_summary}" if s.physics_summary else "")
        )


class NUTTY_OT_clear_limits(_NuttyOperator):
    """Remove the markers and colours of the last limit check"""

    bl_idname = "nutty.clear_limits"
    bl_label = "Clear limits"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context: Any) -> None:
        limits.clear(context.scene, rig.find_rig(context))


class NUTTY_OT_ghost(_NuttyOperator):
    """Show the motion filter's version of the action on a translucent copy of the rig"""

    bl_idname = "nutty.ghost"
    bl_label = "Ghost"
    bl_options = {"REGISTER", "UNDO"}

    preset: EnumProperty(name="Filter", items=[("PANEL", "As in the panel", ""), *PRESETS], default="PANEL")

    def run(self, context: Any) -> str:
        ob = rig_of(context)
        preset = context.scene.nutty.ghost_preset if self.preset == "PANEL" else self.preset
        g, result, notes = ghost.make_ghost(
            context,
            client_of(context),
            ob,
            None if preset == "PROGRAM" else preset,
            context.scene.nutty.ghost_offset,
        )
        self.warn(notes)
        return f"ghost '{g.name}': {len(result['tracks'])} DoFs through filter {result['preset']}"


class NUTTY_OT_remove_ghost(_NuttyOperator):
    """Remove the rig's ghost"""

    bl_idname = "nutty.remove_ghost"
    bl_label = "Remove ghost"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context: Any) -> None:
        g = ghost.ghost_of(context.scene, rig_of(context))
        if g is not None:
            load.remove_rig(g)


class NUTTY_OT_live_link(_NuttyOperator):
    """Stream the rig's pose to the running robot's puppet layer (on/off)"""

    bl_idname = "nutty.live_link"
    bl_label = "Live link"

    action: EnumProperty(
        name="Action",
        items=[("TOGGLE", "Toggle", ""), ("START", "Start", ""), ("STOP", "Stop", "")],
        default="TOGGLE",
    )

    def run(self, context: Any) -> str:
        link = live.LINK
        if self.action == "STOP" or (self.action == "TOGGLE" and link.running):
            link.stop()
            return "live link off: the robot's puppet layer fades out"
        link.start(client_of(context), rig_of(context))
        return f"live link on: {link.status}"


CLASSES = (
    NUTTY_OT_load_robot,
    NUTTY_OT_export_clip,
    NUTTY_OT_import_clip,
    NUTTY_OT_check_limits,
    NUTTY_OT_clear_limits,
    NUTTY_OT_ghost,
    NUTTY_OT_remove_ghost,
    NUTTY_OT_live_link,
)
