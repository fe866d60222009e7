"""Where the add-on shows up: the Nutty menu in the top bar (Load robot, Export clip, Check limits,
Ghost, Live link) and the Nutty tab of the 3D view's sidebar (settings, the limits list, the link)."""

from typing import Any

import bpy

from . import live, rig

KIND_ICONS = {
    "velocity": "SEQUENCE_COLOR_02",
    "acceleration": "SEQUENCE_COLOR_06",
    "jerk": "SEQUENCE_COLOR_01",
    "position": "SEQUENCE_COLOR_05",
}  # orange, pink, red, purple: the editor's colours


class NUTTY_MT_menu(bpy.types.Menu):
    bl_idname = "NUTTY_MT_menu"
    bl_label = "Nutty"

    def draw(self, context: Any) -> None:
        layout = self.layout
        layout.operator("nutty.load_robot", icon="ARMATURE_DATA")
        layout.operator("nutty.export_clip", icon="EXPORT")
        layout.operator("nutty.import_clip", icon="IMPORT")
        layout.operator("nutty.check_limits", icon="ERROR")
        layout.operator("nutty.ghost", icon="GHOST_ENABLED")
        layout.operator(
            "nutty.live_link",
            text="Live link (stop)" if live.LINK.running else "Live link",
            icon="LINKED" if live.LINK.running else "UNLINKED",
        )


class NUTTY_UL_ranges(bpy.types.UIList):
    def draw_item(
        self,
        context: Any,
        layout: Any,
        data: Any,
        item: Any,
        icon: Any,
        active_data: Any,
        active_prop: str,
        index: int = 0,
        flt_flag: int = 0,
    ) -> None:
        row = layout.row(align=True)
        row.label(text=item.bone or item.dof, icon=KIND_ICONS.get(item.kind, "ERROR"))
        row.label(text=item.kind)
        row.label(text=f"{item.frame_start}-{item.frame_end}")
        row.label(text=item.limits or f"{item.worst_ratio:.1f}x")


class NUTTY_PT_panel(bpy.types.Panel):
    bl_label = "Nutty"
    bl_idname = "NUTTY_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Nutty"

    def draw(self, context: Any) -> None:
        layout = self.layout
        s = context.scene.nutty
        col = layout.column(align=True)
        col.prop(s, "server_url")
        col.prop(context.window_manager, "nutty_token")
        layout.operator("nutty.load_robot", icon="ARMATURE_DATA")
        ob = rig.find_rig(context)
        if ob is None:
            layout.label(text="No rig yet: load the robot", icon="INFO")
            return
        box = layout.box()
        box.prop(s, "clip_name")
        if not s.clip_name and ob.animation_data and ob.animation_data.action:
            box.label(text=f"(default: {ob.animation_data.action.name})")
        box.prop(s, "export_target", expand=True)
        if s.export_target == "FILE":
            box.prop(s, "export_path")
        row = box.row(align=True)
        row.operator("nutty.export_clip", icon="EXPORT")
        row.operator("nutty.import_clip", icon="IMPORT")
        box = layout.box()
        row = box.row(align=True)
        row.operator("nutty.check_limits", icon="ERROR")
        row.prop(s, "check_physics", text="", icon="PHYSICS")
        row.operator("nutty.clear_limits", text="", icon="X")
        if s.check_summary:
            box.label(text=s.check_summary)
        if s.physics_summary:
            box.label(text=s.physics_summary, icon="PHYSICS")
        if s.suggestion:
            box.label(text=s.suggestion, icon="TIME")
        if len(s.ranges):
            box.template_list("NUTTY_UL_ranges", "", s, "ranges", s, "ranges_index", rows=4)
        box = layout.box()
        box.prop(s, "ghost_preset")
        box.prop(s, "ghost_offset")
        row = box.row(align=True)
        row.operator("nutty.ghost", icon="GHOST_ENABLED")
        row.operator("nutty.remove_ghost", text="", icon="X")
        box = layout.box()
        link = live.LINK
        box.operator(
            "nutty.live_link",
            text="Stop live link" if link.running else "Start live link",
            icon="LINKED" if link.running else "UNLINKED",
            depress=link.running,
        )
        box.label(text=link.status)
        if link.server_error:
            box.label(text=f"server: {link.server_error}", icon="ERROR")


def draw_topbar(self: Any, context: Any) -> None:
    self.layout.menu(NUTTY_MT_menu.bl_idname)


CLASSES = (NUTTY_MT_menu, NUTTY_UL_ranges, NUTTY_PT_panel)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_editor_menus.append(draw_topbar)


def unregister() -> None:
    bpy.types.TOPBAR_MT_editor_menus.remove(draw_topbar)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
