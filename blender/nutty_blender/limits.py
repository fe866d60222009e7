"""Nutty > Check limits: the trajectory-helper on the exported clip (POST /api/analyze, judged at the
engine's rate by the server, see preview.py), shown where animators look — a timeline marker at the
start of every offending range (`nutty:<kind> <dof> <ratio>x`: the limit that breaks), the offending
bones and F-curves in the editor's colours (velocity orange, acceleration pink, jerk red, position
purple), the list in the Nutty panel (bone, kind, frames, worst ratio, every limit broken), and the
server's suggestion (e.g. "play it 1.8x slower (2 s -> 3.6 s) to fit every limit"; an older server
gives none).

With the panel's Physics switch the server also plays the clip in MuJoCo (`physics: true`,
docs/simulation.md): the panel says what the motors made of it, raw and through the program's filter
(the worst tracking error, the motors that saturated), and every contact gets a marker
(`nutty:contact <link>/<link>`) where it begins.
"""

from __future__ import annotations

from typing import Any

from . import clip, preview, rig
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
    scene.nutty.suggestion = ""
    scene.nutty.physics_summary = ""
    if rig_ob is None:
        return
    for pb in rig_ob.pose.bones:
        pb.color.palette = "DEFAULT"
    for fc in rig.fcurves(rig_ob):
        fc.color_mode = "AUTO_RAINBOW"


def check_limits(context: Any, client: Client, rig_ob: Any) -> tuple[dict[str, Any], list[str]]:
    """Post the exported clip, show the verdict, and return it (the server's JSON) with the export's
    notes."""
    plan = rig.plan_of(rig_ob)
    timing = clip.Timing.of(context.scene)
    extra = {"physics": True} if context.scene.nutty.check_physics else None
    result, notes = preview.post(client, "/api/analyze", context.scene, rig_ob, plan, extra)
    show(context.scene, rig_ob, plan, timing, result)
    show_physics(context.scene, timing, result.get("physics"))
    return result, notes


def physics_text(report: dict[str, Any]) -> str:
    """`physics: head_pitch off by 0.026 rad raw, 0.009 filtered; saturated: neck (raw); 1 contact`."""
    raw, filtered = report["raw"], report["filtered"]
    worst = filtered["worst_joint"] or raw["worst_joint"]
    parts = []
    if worst:
        parts.append(
            f"{worst} off by {raw['joints'][worst]['peak_error']:.3f} raw, "
            f"{filtered['joints'][worst]['peak_error']:.3f} filtered"
        )
    for label, run in (("raw", raw), ("filtered", filtered)):
        if run["saturated_joints"]:
            parts.append(f"saturated: {', '.join(run['saturated_joints'])} ({label})")
    n = len(filtered["contacts"])
    parts.append(f"{n} contact{'s' if n != 1 else ''}" if n else "no contacts")
    return "physics: " + "; ".join(parts)


def show_physics(scene: Any, timing: clip.Timing, report: dict[str, Any] | None) -> None:
    """The physics verdict in the panel, and a marker where each contact of the filtered clip begins."""
    if not report:
        return
    scene.nutty.physics_summary = physics_text(report)
    for c in report["filtered"]["contacts"]:
        frame = int(timing.start) + round(c["first"] * timing.fps)
        scene.timeline_markers.new(f"{MARKER_PREFIX}contact {'/'.join(c['links'])}", frame=frame)


def _limits_text(r: dict[str, Any]) -> str:
    """`velocity 2.1x, jerk 5.3x`: every limit the range breaks (an older server: its kind only)."""
    broken = r.get("limits") or {r["kind"]: r["worst_ratio"]}
    return ", ".join(f"{kind} {ratio:.1f}x" for kind, ratio in broken.items())


def show(scene: Any, rig_ob: Any, plan: Any, timing: clip.Timing, result: dict[str, Any]) -> None:
    clear(scene, rig_ob)
    colours = {k: hex_colour(v) for k, v in result.get("colours", {}).items()}
    start = int(timing.start)
    worst: dict[str, str] = {}  # DoF -> most severe kind
    bones = rig.control_bones(rig_ob, plan)  # (by the bones' DoF: renamed bones too)
    for r in result["ranges"]:
        dof, kind = r["dof"], r["kind"]
        first, last = start + r["start"], start + r["end"]
        scene.timeline_markers.new(f"{MARKER_PREFIX}{kind} {dof} {r['worst_ratio']:.1f}x", frame=first)
        item = scene.nutty.ranges.add()
        item.dof, item.bone, item.kind = dof, bones.get(dof, ""), kind
        item.frame_start, item.frame_end, item.worst_ratio = first, last, r["worst_ratio"]
        item.limits = _limits_text(r)
        if SEVERITY.index(kind) > SEVERITY.index(worst.get(dof, kind)) or dof not in worst:
            worst[dof] = kind
    for dof, kind in worst.items():
        colour = colours.get(kind, (1.0, 0.0, 0.0))
        bone = bones.get(dof)
        if bone is not None:
            c = rig_ob.pose.bones[bone].color
            c.palette = "CUSTOM"
            c.custom.normal, c.custom.select, c.custom.active = colour, colour, (1.0, 1.0, 1.0)
    paths = {v: k for k, v in rig.dof_paths(rig_ob, plan).items()}
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
    scene.nutty.suggestion = str(result.get("suggestion") or "")  # (an older server suggests nothing)
