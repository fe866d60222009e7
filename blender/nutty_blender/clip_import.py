"""Nutty > Import clip: a clip of the robot's library (GET /api/clips/{name}) as a new action on the rig,
the inverse of Export clip, so exporting it again gives the same clip back.

Clip time t (s) lands on frame = the scene's start frame + t x fps (fractional frames are kept); the
scene's end frame becomes the clip's end. Continuous tracks become F-curves on the control bones' Y
rotation (rad) or the symbolic and display properties; constant and linear keys stay so; Bezier keys
get FREE handles at the absolute (frame, value) points the engine resolves from the clip's (dt s, dv)
offsets and handle types (curve_math.py); easings Blender computes like the engine stay easings, the
others (expo, elastic, back in-out) are baked into one Bezier piece per frame of the engine's curve,
with a note. Colour tracks become the colour property's r, g, b curves (linear or constant), enum
tracks the option's index (constant). Anchors become `anchor:<name>` timeline markers, events
`say:<text>` and `sound:<name>` markers (markers sit on whole frames: a note says when one moved).
"""

from __future__ import annotations

import math
import urllib.parse
from typing import Any

import bpy

from . import clip, rig
from .client import Client, NuttyError
from .curve_math import ease, resolve_handles

BLENDER_EASING = {"in": "EASE_IN", "out": "EASE_OUT", "in_out": "EASE_IN_OUT"}
EXACT = {"sine", "quad", "cubic", "quart", "quint", "circ", "bounce"}  # + back in or out
MARKERS = ("anchor", "say", "sound")


def _exact(key: dict[str, Any]) -> bool:
    interp, mode = key.get("interp", "bezier"), key.get("easing", "in_out")
    return interp in EXACT or (interp == "back" and mode != "in_out")


def _ensure_curve(rig_ob: Any, path: str, index: int) -> Any:
    """The F-curve `path[index]` of the rig's (new, assigned) action, emptied."""
    action = rig_ob.animation_data.action
    if hasattr(action, "fcurve_ensure_for_datablock"):  # Blender 4.4+: slotted actions
        fc = action.fcurve_ensure_for_datablock(rig_ob, path, index=index)
    else:
        fc = action.fcurves.find(path, index=index) or action.fcurves.new(path, index=index)
    fc.keyframe_points.clear()
    return fc


def _eased_pieces(k0: dict, k1: dict, fps: float, start: float) -> list[tuple[float, float, float]]:
    """(frame, value, slope per frame) at the ends of one piece per frame of an eased segment."""
    f0, f1 = start + k0["t"] * fps, start + k1["t"] * fps
    pieces = max(1, math.ceil(f1 - f0 - 1e-9))
    name, mode, v0, dv = k0["interp"], k0.get("easing", "in_out"), k0["v"], k1["v"] - k0["v"]

    def value(u: float) -> float:
        return v0 + ease(name, mode, u) * dv

    out = []
    for j in range(pieces + 1):
        u, h = j / pieces, 1e-6
        lo, hi = max(u - h, 0.0), min(u + h, 1.0)
        out.append((f0 + u * (f1 - f0), value(u), (value(hi) - value(lo)) / (hi - lo) / (f1 - f0)))
    return out


def _points(
    keys: list[dict[str, Any]], fps: float, start: float, notes: list[str], where: str
) -> list[dict[str, Any]]:
    """Blender key points (co, interpolation, easing, absolute left/right handles in (frame, value)) of
    numeric clip keys."""
    handles = resolve_handles(keys)
    points: list[dict[str, Any]] = []
    baked = set()
    pending = None  # the left handle of the next key, set by a baked segment before it
    for i, k in enumerate(keys):
        interp = k.get("interp", "bezier")
        (lt, lv), (rt, rv) = handles[i]
        left = pending if pending is not None else (start + lt * fps, lv)
        pending = None
        p = {"co": (start + k["t"] * fps, k["v"]), "interp": interp.upper(), "easing": None}
        p["left"], p["right"] = left, (start + rt * fps, rv)
        if interp not in ("constant", "linear", "bezier") and i + 1 < len(keys) and not _exact(k):
            baked.add(f"{interp} {k.get('easing', 'in_out')}")  # Blender's expo/elastic/back in-out differ
            pieces, pending = _hermite(_eased_pieces(k, keys[i + 1], fps, start))
            pieces[0]["left"] = left
            points.extend(pieces)
            continue
        if interp not in ("constant", "linear", "bezier"):
            p["easing"] = BLENDER_EASING[k.get("easing", "in_out")]
        points.append(p)
    if baked:
        notes.append(
            f"{where}: {', '.join(sorted(baked))} baked into per-frame Bezier keys of the engine's curve "
            f"(Blender eases differently)"
        )
    return points


def _hermite(
    pieces: list[tuple[float, float, float]],
) -> tuple[list[dict[str, Any]], tuple[float, float]]:
    """Bezier points through (frame, value, slope per frame) samples, handles a third of each piece
    long, all but the last sample; and the last sample's left handle (for the key it lands on)."""
    out: list[dict[str, Any]] = []
    for j, (f, v, s) in enumerate(pieces[:-1]):
        step_r = pieces[j + 1][0] - f
        step_l = f - pieces[j - 1][0] if j > 0 else step_r
        out.append(
            {
                "co": (f, v),
                "interp": "BEZIER",
                "easing": None,
                "left": (f - step_l / 3, v - s * step_l / 3),
                "right": (f + step_r / 3, v + s * step_r / 3),
            }
        )
    f, v, s = pieces[-1]
    step = f - pieces[-2][0]
    return out, (f - step / 3, v - s * step / 3)


def _write(fc: Any, points: list[dict[str, Any]]) -> None:
    fc.keyframe_points.add(len(points))
    for kp, p in zip(fc.keyframe_points, points):
        kp.co = p["co"]
        kp.interpolation = p["interp"]
        if p.get("easing"):
            kp.easing = p["easing"]
        if p["interp"] == "BACK":
            kp.back = 1.70158
        kp.handle_left_type = kp.handle_right_type = "FREE"
        kp.handle_left, kp.handle_right = p.get("left", p["co"]), p.get("right", p["co"])
    fc.update()


def _track(
    rig_ob: Any,
    plan: Any,
    dof: str,
    keys: list[dict[str, Any]],
    doc: dict[str, Any],
    at: Any,
    notes: list[str],
) -> bool:
    """Write one track onto the rig's action; False when the rig has no channel for it."""
    fps, start = at
    props = {p.name: p for p in plan.props}
    bones = rig.control_bones(rig_ob, plan)
    if dof in bones or (dof in props and props[dof].kind == "float"):
        rest = next((b.rest for b in plan.bones if b.dof == dof), None)
        rest = rest if rest is not None else float(props[dof].default) if dof in props else 0.0
        offset = rest if doc.get("relative") else 0.0  # a relative clip's values are offsets from rest
        numeric = [{**k, "v": float(k["v"]) + offset} for k in keys]
        path, index = (rig.bone_path(bones[dof]), rig.DOF_INDEX) if dof in bones else (f'["{dof}"]', 0)
        _write(_ensure_curve(rig_ob, path, index), _points(numeric, fps, start, notes, f"'{dof}'"))
        return True
    prop = props.get(dof)
    if prop is not None and prop.kind == "colour":
        for c in range(3):
            _write(
                _ensure_curve(rig_ob, f'["{dof}"]', c),
                [
                    {
                        "co": (start + k["t"] * fps, float(k["v"][c])),
                        "easing": None,
                        "interp": "CONSTANT" if k.get("interp") == "constant" else "LINEAR",
                    }
                    for k in keys
                ],
            )
        return True
    if prop is not None and prop.kind == "enum":
        points = [
            {
                "co": (start + k["t"] * fps, float(_option(prop, k["v"], dof))),
                "interp": "CONSTANT",
                "easing": None,
            }
            for k in keys
        ]
        _write(_ensure_curve(rig_ob, f'["{dof}"]', 0), points)
        return True
    return False


def _option(prop: Any, v: Any, dof: str) -> int:
    if isinstance(v, str) and v in prop.options:
        return prop.options.index(v)
    if isinstance(v, (int, float)) and 0 <= int(v) < len(prop.options):
        return int(v)
    raise clip.ExportError(f"track '{dof}': '{v}' is not one of {', '.join(prop.options)}")


def _markers(scene: Any, doc: dict[str, Any], at: Any, notes: list[str]) -> None:
    """The clip's anchors and say/sound events as timeline markers (replacing the scene's earlier ones)."""
    fps, start = at
    for m in [m for m in scene.timeline_markers if m.name.partition(":")[0].strip().lower() in MARKERS]:
        scene.timeline_markers.remove(m)
    items = [(f"anchor:{name}", t) for name, t in (doc.get("anchors") or {}).items()]
    for e in doc.get("events") or []:
        payload = e.get("payload") or {}
        if e.get("kind") == "say" and payload.get("text"):
            items.append((f"say:{payload['text']}", e["t"]))
        elif e.get("kind") == "sound" and payload.get("clip"):
            items.append((f"sound:{payload['clip']}", e["t"]))
        else:
            notes.append(f"event '{e.get('kind')}' at {e.get('t')} s has no marker form: not imported")
    for name, t in items:
        frame = start + t * fps
        if abs(frame - round(frame)) > 1e-6:
            notes.append(
                f"marker '{name}' at {t:g} s moved to frame {round(frame)} (markers sit on whole frames)"
            )
        scene.timeline_markers.new(name, frame=round(frame))


def apply_clip(scene: Any, rig_ob: Any, plan: Any, doc: dict[str, Any]) -> tuple[Any, list[str]]:
    """`doc` (a nutty-clip/1 document) as a new action on `rig_ob` (see the module doc): the action and
    notes for the report. ExportError for a track the rig cannot take."""
    timing = clip.Timing.of(scene)
    at = (timing.fps, timing.start)
    tracks = doc.get("tracks") or {}
    if not tracks:
        raise clip.ExportError(f"clip '{doc.get('name')}' has no tracks")
    notes: list[str] = []
    action = bpy.data.actions.new(str(doc.get("name") or "clip"))
    ad = rig_ob.animation_data_create()
    ad.action = action
    skipped = [
        dof for dof, keys in tracks.items() if keys and not _track(rig_ob, plan, dof, keys, doc, at, notes)
    ]
    if skipped:
        notes.append(f"tracks the rig has no channel for, not imported: {', '.join(skipped)}")
    duration = doc.get("duration") or max(keys[-1]["t"] for keys in tracks.values() if keys)
    frames = float(duration) * timing.fps
    if abs(frames - round(frames)) > 1e-6:
        notes.append(f"the clip lasts {duration:g} s, {frames:.3f} frames: the end frame is rounded")
    scene.frame_end = int(timing.start) + max(1, round(frames))
    _markers(scene, doc, at, notes)
    return action, notes


def import_clip(context: Any, client: Client, rig_ob: Any, name: str) -> tuple[Any, list[str]]:
    """GET the clip `name` from the robot's library and apply it (apply_clip). NuttyError when the
    server has no such clip."""
    if not name:
        raise NuttyError("name the clip to import (the Nutty panel's Clip field)")
    doc = client.get(f"/api/clips/{urllib.parse.quote(name, safe='')}")
    if not isinstance(doc, dict) or doc.get("format") != "nutty-clip/1":
        raise NuttyError(f"'{name}' from {client.url} is not a nutty-clip/1 clip")
    return apply_clip(context.scene, rig_ob, rig.plan_of(rig_ob), doc)
