"""Nutty > Check limits: the trajectory-helper on the action (POST /api/analyze), shown where animators
look — a timeline marker at the start of every offending range (`nutty:<kind> <dof> <ratio>x`), the
offending bones and F-curves in the editor's colours (velocity orange, acceleration pink, jerk red,
position purple), and the list in the Nutty panel (bone, kind, frames, worst ratio).
"""

from __future__ import annotations

from typing import Any

from . import clip, rig
from .client import Client

MARKER_PREFIX = "nutty:"
SEVERITY = ("velocity", "acceleration", "jerk", "position")  # the most severe last (as in the editor)


def hex_colour(value: str) -> tuple[float, float, float]:
    value = value.lstrip("#")
    return (int(value[0:2], 16) / 255.0, int(value[2:4], 16) / 255.0, int(value[4:6], 16) / 255.0)


def clear(scene: Any, rig_ob: Any | None) -> None:
    """Remove what an earlier check showed: its markers, list, bone and F-curve colours."""
    for m in [m for m in scene.timeline_markers if m.name.startswith(MARKER_PREFIX)]:
        scene.timeline_markers.remove(m)
    scene.nutty.ranges.clear()
    scene.nutty.check_summary = ""
    if rig_ob is None:
        return
    for pb in rig_ob.pose.bones:
        pb.color.palette = "DEFAULT"
    for fc in rig.fcurves(rig_ob):
        fc.color_mode = "AUTO_RAINBOW"


def check_limits(context: Any, client: Client, rig_ob: Any) -> dict[str, Any]:
    """Post the action's sampled tracks, show the verdict, and return it (the server's JSON)."""
    plan = rig.plan_of(rig_ob)
    timing = clip.Timing.of(context.scene)
    tracks = clip.sample_tracks(rig_ob, plan, timing)
    if not tracks:
        raise clip.ExportError(f"'{rig_ob.name}' has no keyed DoFs to check: key some bones (I) first")
    result = client.post("/api/analyze", {"rate": timing.fps, "tracks": tracks})
    show(context.scene, rig_ob, plan, timing, result)
    return result


def show(scene: Any, rig_ob: Any, plan: Any, timing: clip.Timing, result: dict[str, Any]) -> None:
    clear(scene, rig_ob)
    colours = {k: hex_colour(v) for k, v in result.get("colours", {}).items()}
    start = int(timing.start)
    worst: dict[str, str] = {}  # DoF -> most severe kind
    for r in result["ranges"]:
        dof, kind = r["dof"], r["kind"]
        first, last = start + r["start"], start + r["end"]
        scene.timeline_markers.new(f"{MARKER_PREFIX}{kind} {dof} {r['worst_ratio']:.1f}x", frame=first)
        item = scene.nutty.ranges.add()
        item.dof, item.bone, item.kind = dof, plan.dof_bones.get(dof, ""), kind
        item.frame_start, item.frame_end, item.worst_ratio = first, last, r["worst_ratio"]
        if SEVERITY.index(kind) > SEVERITY.index(worst.get(dof, kind)) or dof not in worst:
            worst[dof] = kind
    for dof, kind in worst.items():
        colour = colours.get(kind, (1.0, 0.0, 0.0))
        bone = plan.dof_bones.get(dof)
        if bone is not None:
            c = rig_ob.pose.bones[bone].color
            c.palette = "CUSTOM"
            c.custom.normal, c.custom.select, c.custom.active = colour, colour, (1.0, 1.0, 1.0)
    paths = {v: k for k, v in rig.dof_paths(plan).items()}
    for fc in rig.fcurves(rig_ob):
        for dof, kind in worst.items():
            if paths.get(dof) == (fc.data_path, fc.array_index):
                fc.color_mode, fc.color = "CUSTOM", colours.get(kind, (1.0, 0.0, 0.0))
    n = len(result["ranges"])
    scene.nutty.check_summary = (
        "within every limit"
        if n == 0
        else f"{n} range{'s' if n != 1 else ''} over the limits on "
        f"{len(worst)} DoF{'s' if len(worst) != 1 else ''}"
    )
