"""The add-on's settings (scene.nutty) and the token (window_manager.nutty_token, never saved in a .blend)."""

# (no `from __future__ import annotations`: Blender reads the property annotations as objects)
import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from .client import DEFAULT_URL

PRESETS = [
    ("PROGRAM", "Running program", "the running program's stage-2 motion filter"),
    ("W", "W regular", "limits only"),
    ("A", "A slow & smooth", ""),
    ("B", "B slow & vivid", ""),
    ("C", "C fast & vivid", ""),
    ("D", "D fast & smooth", ""),
    ("E", "E fast & very smooth", ""),
]


class NuttyRange(bpy.types.PropertyGroup):
    """One range of frames over a limit (Check limits)."""

    dof: StringProperty(name="DoF")
    bone: StringProperty(name="Bone")
    kind: StringProperty(name="Kind", description="velocity, acceleration, jerk or position")
    frame_start: IntProperty(name="From")
    frame_end: IntProperty(name="To")
    worst_ratio: FloatProperty(
        name="Worst", description="the worst value over the limit, as a multiple of it"
    )
    limits: StringProperty(name="Limits", description="every limit broken in the range, worst ratio each")


class NuttySettings(bpy.types.PropertyGroup):
    server_url: StringProperty(
        name="Server", default=DEFAULT_URL, description="the address of a running `nutty serve`"
    )
    clip_name: StringProperty(
        name="Clip", default="", description="name of the exported clip (default: the action's name)"
    )
    export_target: EnumProperty(
        name="Export to",
        default="SERVER",
        items=[
            ("SERVER", "Server", "save in the robot's library (PUT /api/clips/{name})"),
            ("FILE", "File", "write a .json file"),
        ],
    )
    export_path: StringProperty(name="File", subtype="FILE_PATH", default="//clip.json")
    ghost_preset: EnumProperty(
        name="Filter", items=PRESETS, default="PROGRAM", description="the motion filter the ghost shows"
    )
    ghost_offset: FloatProperty(
        name="Beside",
        default=-1.0,
        min=-1.0,
        soft_max=2.0,
        unit="LENGTH",
        description="how far to the robot's left the ghost stands (m): 0 overlays it on "
        "the rig, -1 puts it one robot width away",
    )
    ranges: CollectionProperty(type=NuttyRange)
    ranges_index: IntProperty()
    check_summary: StringProperty(name="Limits")
    check_physics: BoolProperty(
        name="Physics",
        default=False,
        description="Check limits also plays the clip in physics on the server (MuJoCo: gravity, motor "
        "strength, self-collision) and shows the tracking error, saturated motors and contacts",
    )
    physics_summary: StringProperty(name="Physics", description="what the motors made of the clip")
    suggestion: StringProperty(
        name="Suggestion", description="the server's advice to fit every limit (e.g. play it slower)"
    )


CLASSES = (NuttyRange, NuttySettings)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.nutty = PointerProperty(type=NuttySettings)
    bpy.types.WindowManager.nutty_token = StringProperty(
        name="Token",
        subtype="PASSWORD",
        options={"SKIP_SAVE"},
        description="the server's --token, if it has one (kept for this session only; or set NUTTY_TOKEN)",
    )


def unregister() -> None:
    del bpy.types.WindowManager.nutty_token
    del bpy.types.Scene.nutty
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
