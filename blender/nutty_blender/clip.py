"""Nutty > Export clip: a rig's action as a `nutty-clip/1` document (docs/program-format.md), and the
action's tracks sampled per frame (what Check limits and Ghost post).

Keys are converted, not resampled: a key's time is (frame - scene start frame) / fps, its value the
F-curve's (rad for a bone, the property's unit otherwise); constant and linear segments stay so;
Bezier segments keep their handles, exported as `free` handles as Blender draws them (a handle longer
than its segment shortened), so the engine draws the very cubic Blender draws; easing presets the engine
computes exactly like Blender (sine, quad, cubic, quart, quint, circ, bounce, back in/out) stay
presets. The rest (expo, elastic, back in-out, a changed back/amplitude/period, and Bezier segments
whose handles overlap so that the curve doubles back in time) are baked into one Bezier piece per frame
from Blender's own evaluation (cubic Hermite: far below 0.01 deg), with a note.
F-curves map to DoFs through the bones as they are (each control bone's `nutty_dof`), so a renamed bone
keeps its DoF. When the motion is not only the active action's keys (NLA strips, constraints, IK,
other drivers, F-curve modifiers), the continuous DoFs are baked from the evaluated pose (bake.py).
Timeline markers `anchor:<name>` become anchors, `say:<text>` and `sound:<name>` events; colour
properties become colour tracks (linear between keys), enum properties option names, the sound
property `sound` events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from . import bake
from .robot import RigPlan

EXACT_EASINGS = {"SINE", "QUAD", "CUBIC", "QUART", "QUINT", "CIRC", "BOUNCE", "BACK"}
DYNAMIC = {"BACK", "BOUNCE", "ELASTIC"}  # Blender's AUTO easing is "out" for these, "in" otherwise
DEFAULT_BACK = 1.70158  # Blender's default overshoot of BACK (the engine's constant)
MODES = {"EASE_IN": "in", "EASE_OUT": "out", "EASE_IN_OUT": "in_out"}
ROUND = 9  # decimals kept in the JSON (Blender stores float32: nothing is lost)


class ExportError(Exception):
    """The action cannot be exported as a clip; the message says which key or marker and why."""


@dataclass(frozen=True)
class Timing:
    """Clip time of Blender frames: frame `start` is t = 0, `fps` frames per second."""

    fps: float
    start: float
    end: float

    @classmethod
    def of(cls, scene: Any) -> Timing:
        return cls(scene.render.fps / scene.render.fps_base, float(scene.frame_start), float(scene.frame_end))

    def t(self, frame: float) -> float:
        return round((frame - self.start) / self.fps, ROUND)

    @property
    def duration(self) -> float:
        return (self.end - self.start) / self.fps

    @property
    def frames(self) -> list[int]:
        return list(range(int(self.start), int(self.end) + 1))


def _r(x: float) -> float:
    return round(float(x), ROUND)


def _bezier_handles(
    p0: Any, h0: Any, h1: Any, p1: Any
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The right handle of key 0 and the left handle of key 1 as offsets (frames, value), as Blender
    draws the segment: a handle reaching past the other key is shortened to the segment's length (both
    coordinates, keeping its slope). None when the segment then doubles back in time (x(u) not
    monotonic, e.g. overlapping handles): Blender then shows one of several curve values at a frame,
    which no function of time reproduces, so the caller bakes it."""
    span = p1[0] - p0[0]
    r = (h0[0] - p0[0], h0[1] - p0[1])
    left = (h1[0] - p1[0], h1[1] - p1[1])
    if abs(r[0]) > span > 0:
        r = (r[0] * span / abs(r[0]), r[1] * span / abs(r[0]))
    if abs(left[0]) > span > 0:
        left = (left[0] * span / abs(left[0]), left[1] * span / abs(left[0]))
    # x(u) of the cubic through 0, r.x, span + left.x, span is monotonic iff its derivative's Bernstein
    # form a(1-u)^2 + 2b u(1-u) + c u^2 (a = r.x, b = span + left.x - r.x, c = -left.x) stays >= 0
    a, b, c = r[0], span + left[0] - r[0], -left[0]
    if a < 0 or c < 0 or b < -math.sqrt(a * c) - 1e-9 * span:
        return None
    return r, left


def _mode(kp: Any) -> str:
    if kp.easing == "AUTO":
        return "out" if kp.interpolation in DYNAMIC else "in"
    return MODES[kp.easing]


def _exact_easing(kp: Any) -> bool:
    if kp.interpolation not in EXACT_EASINGS:
        return False
    if kp.interpolation == "BACK":  # the engine's back is Blender's at the default overshoot, in or out
        return abs(kp.back - DEFAULT_BACK) < 1e-6 and _mode(kp) != "in_out"
    return True


def _slope(fc: Any, frame: float, inside: float) -> float:
    """d value / d frame at `frame`, from the side of `inside` (+1 after, -1 before), second order."""
    h = 1e-3 * inside
    return (-3 * fc.evaluate(frame) + 4 * fc.evaluate(frame + h) - fc.evaluate(frame + 2 * h)) / (2 * h)


def _baked(fc: Any, f0: float, f1: float, timing: Timing) -> list[dict[str, Any]]:
    """Keys from f0 to f1 (both ends), one Bezier piece per frame at most, each piece the cubic Hermite
    of Blender's evaluation (values and slopes at its ends, taken from inside the segment). The first
    key has only a right handle, the last only a left one."""
    pieces = max(1, math.ceil(f1 - f0 - 1e-9))
    step = (f1 - f0) / pieces
    keys = []
    for k in range(pieces + 1):
        f = f0 + k * step
        key: dict[str, Any] = {
            "t": timing.t(f),
            "v": _r(fc.evaluate(min(f, f1 - 1e-6)) if k == pieces else fc.evaluate(f)),
        }
        if k > 0:
            d = _slope(fc, f, -1.0) if k == pieces else (fc.evaluate(f + 1e-3) - fc.evaluate(f - 1e-3)) / 2e-3
            key["left_type"], key["left"] = "free", [_r(-step / 3 / timing.fps), _r(-d * step / 3)]
        if k < pieces:
            d = _slope(fc, f, 1.0) if k == 0 else (fc.evaluate(f + 1e-3) - fc.evaluate(f - 1e-3)) / 2e-3
            key.update(
                interp="bezier", right_type="free", right=[_r(step / 3 / timing.fps), _r(d * step / 3)]
            )
        keys.append(key)
    return keys


def curve_keys(fc: Any, timing: Timing, where: str, notes: list[str]) -> list[dict[str, Any]]:
    """A numeric F-curve's keys as clip keys (see the module doc); ExportError for keys before t = 0."""
    points = sorted(fc.keyframe_points, key=lambda kp: kp.co[0])
    if points and points[0].co[0] < timing.start - 1e-6:
        raise ExportError(
            f"{where}: a key at frame {points[0].co[0]:g} is before the scene's start frame "
            f"{timing.start:g} (clip time 0): move the key or the start frame"
        )
    lefts: dict[int, list[float]] = {}  # key index -> its left handle, set by the segment before it
    keys: list[dict[str, Any]] = []
    baked: set[str] = set()
    for i, kp in enumerate(points):
        key: dict[str, Any] = {"t": timing.t(kp.co[0]), "v": _r(kp.co[1])}
        if i in lefts:
            key["left_type"], key["left"] = "free", lefts[i]
        nxt = points[i + 1] if i + 1 < len(points) else None
        ipo = kp.interpolation
        if ipo == "CONSTANT":
            key["interp"] = "constant"
        elif nxt is None or ipo == "LINEAR":
            key["interp"] = "linear"  # (the last key's interpolation leads nowhere)
        elif ipo == "BEZIER" and (
            handles := _bezier_handles(kp.co, kp.handle_right, nxt.handle_left, nxt.co)
        ):
            right, left = handles
            key.update(interp="bezier", right_type="free", right=[_r(right[0] / timing.fps), _r(right[1])])
            lefts[i + 1] = [_r(left[0] / timing.fps), _r(left[1])]
        elif ipo != "BEZIER" and _exact_easing(kp):
            key["interp"], key["easing"] = ipo.lower(), _mode(kp)
        else:
            baked.add("overlapping Bezier handle" if ipo == "BEZIER" else ipo.lower())
            pieces = _baked(fc, kp.co[0], nxt.co[0], timing)
            key.update({k: pieces[0][k] for k in ("interp", "right_type", "right")})
            keys.append(key)
            keys.extend(pieces[1:-1])
            lefts[i + 1] = pieces[-1]["left"]
            continue
        keys.append(key)
    if baked:
        notes.append(
            f"{where}: {', '.join(sorted(baked))} segments were baked into per-frame Bezier keys "
            f"(the engine draws them differently from Blender)"
        )
    return keys


def _prop_name(data_path: str) -> str | None:
    """`name` of a custom property path `["name"]`, else None."""
    if data_path.startswith('["') and data_path.endswith('"]'):
        return data_path[2:-2]
    return None


def _colour_keys(name: str, curves: dict[int, Any], timing: Timing, notes: list[str]) -> list[dict[str, Any]]:
    """One colour track from a colour property's r, g, b F-curves: a key wherever any of them has one,
    linear between keys (the engine blends colours linearly), constant where all three hold."""
    frames = sorted({kp.co[0] for fc in curves.values() for kp in fc.keyframe_points})
    smooth = {kp.interpolation for fc in curves.values() for kp in fc.keyframe_points} - {
        "CONSTANT",
        "LINEAR",
    }
    if smooth:
        kinds = ", ".join(sorted(smooth)).lower()
        notes.append(
            f"'{name}': colours blend linearly between keys in the engine ({kinds} keys become linear)"
        )
    keys = []
    for f in frames:
        if f < timing.start - 1e-6:
            raise ExportError(
                f"'{name}': a key at frame {f:g} is before the scene's start frame {timing.start:g}"
            )
        rgb = [min(max(_r(curves[c].evaluate(f)) if c in curves else 0.0, 0.0), 1.0) for c in range(3)]
        held = all(
            kp.interpolation == "CONSTANT"
            for fc in curves.values()
            for kp in fc.keyframe_points
            if abs(kp.co[0] - f) < 1e-6
        )
        keys.append({"t": timing.t(f), "v": rgb, "interp": "constant" if held else "linear"})
    return keys


def _marker_items(scene: Any, plan: RigPlan, timing: Timing) -> tuple[dict[str, float], list[dict[str, Any]]]:
    """Anchors and events from the timeline markers `anchor:`, `say:` and `sound:` (others are ignored)."""
    anchors: dict[str, float] = {}
    events: list[dict[str, Any]] = []
    sounds = next((p.options[1:] for p in plan.props if p.kind == "sound"), [])
    for m in sorted(scene.timeline_markers, key=lambda m: m.frame):
        kind, sep, text = m.name.partition(":")
        kind, text = kind.strip().lower(), text.strip()
        if not sep or kind not in ("anchor", "say", "sound"):
            continue
        where = f"marker '{m.name}' at frame {m.frame}"
        if not timing.start <= m.frame <= timing.end:
            raise ExportError(f"{where} is outside the scene's frame range {timing.start:g}-{timing.end:g}")
        if not text:
            raise ExportError(f"{where} has nothing after '{kind}:'")
        t = timing.t(m.frame)
        if kind == "anchor":
            if text in anchors:
                raise ExportError(f"{where}: anchor '{text}' is already at {anchors[text]:g} s")
            anchors[text] = t
        elif kind == "say":
            if plan.speech is None:
                raise ExportError(f"{where}: robot '{plan.robot}' has no speech DoF")
            events.append({"t": t, "dof": plan.speech, "kind": "say", "payload": {"text": text}})
        else:
            if plan.sound is None:
                raise ExportError(f"{where}: robot '{plan.robot}' has no sound DoF")
            if sounds and text not in sounds:
                raise ExportError(f"{where}: '{text}' is not one of the robot's sounds ({', '.join(sounds)})")
            events.append({"t": t, "dof": plan.sound, "kind": "sound", "payload": {"clip": text}})
    return anchors, events


def _discrete_keys(
    prop: Any, fc: Any, timing: Timing, tracks: dict[str, Any], events: list[dict[str, Any]], notes: list[str]
) -> None:
    """An enum property's keys as option names (constant), a sound property's keys as sound events.
    Their keys are made constant in Blender too: an integer property between Bezier or linear keys
    shows the options in between, which the engine never plays."""
    if any(kp.interpolation != "CONSTANT" for kp in fc.keyframe_points):
        for kp in fc.keyframe_points:
            kp.interpolation = "CONSTANT"
        fc.update()
        notes.append(f"'{prop.name}': its keys now hold (constant), as the engine plays them")
    for kp in sorted(fc.keyframe_points, key=lambda k: k.co[0]):
        if kp.co[0] < timing.start - 1e-6:
            raise ExportError(f"'{prop.name}': a key at frame {kp.co[0]:g} is before the start frame")
        index = min(max(round(kp.co[1]), 0), len(prop.options) - 1)
        t = timing.t(kp.co[0])
        if prop.kind == "enum":
            tracks.setdefault(prop.name, []).append({"t": t, "v": prop.options[index], "interp": "constant"})
        elif index > 0:  # a key on a sound plays it
            events.append(
                {"t": t, "dof": prop.name, "kind": "sound", "payload": {"clip": prop.options[index]}}
            )


def _curve_tracks(
    rig_ob: Any, plan: RigPlan, curves: list[Any], timing: Timing, notes: list[str], baking: bool
) -> tuple[dict[str, list[dict[str, Any]]], list[dict[str, Any]]]:
    """Tracks and sound events from the active action's F-curves (see the module doc). `baking`: the
    continuous DoFs are baked from the evaluated pose instead, so their curves are skipped here."""
    from .rig import dof_paths  # (rig imports bpy: only in Blender)

    paths = dof_paths(rig_ob, plan)
    props = {p.name: p for p in plan.props}
    tracks: dict[str, list[dict[str, Any]]] = {}
    events: list[dict[str, Any]] = []
    colours: dict[str, dict[int, Any]] = {}
    ignored: list[str] = []
    for fc in curves:
        where = f"'{fc.data_path}[{fc.array_index}]'"
        dof = paths.get((fc.data_path, fc.array_index))
        prop = props.get(_prop_name(fc.data_path) or "")
        if baking and dof is not None:
            continue
        if fc.mute:
            notes.append(f"{where} is muted: not exported")
            continue
        if len(fc.modifiers):
            notes.append(f"{where}: F-curve modifiers are not exported (bake them into keys first)")
        if fc.extrapolation != "CONSTANT":
            notes.append(
                f"{where}: the engine holds the first and last values (no {fc.extrapolation.lower()} "
                f"extrapolation)"
            )
        if dof is not None:
            tracks[dof] = curve_keys(fc, timing, f"'{dof}'", notes)
        elif prop is not None and prop.kind == "colour":
            colours.setdefault(prop.name, {})[fc.array_index] = fc
        elif prop is not None and prop.kind in ("enum", "sound"):
            _discrete_keys(prop, fc, timing, tracks, events, notes)
        else:
            ignored.append(where)
    for cname, rgb in colours.items():
        tracks[cname] = _colour_keys(cname, rgb, timing, notes)
    if ignored:
        notes.append(f"not DoFs of the robot, not exported: {', '.join(ignored)}")
    return tracks, events


def _evaluated_tracks(
    rig_ob: Any, plan: RigPlan, scene: Any, reasons: list[str], notes: list[str], keyed: set[str]
) -> dict[str, Any]:
    """The continuous DoFs baked from the evaluated pose (bake.py), with a note saying why."""
    import bpy  # (Blender's module: the export runs in Blender)

    from . import rig  # (rig imports bpy: only in Blender)

    for dof in rig.missing_dofs(rig_ob, plan):
        notes.append(f"DoF '{dof}' has no bone in '{rig_ob.name}' (deleted?): not baked; Load robot again")
    timing = Timing.of(scene)
    bones = rig.control_bones(rig_ob, plan)
    tracks = bake.baked_tracks(rig_ob, plan, bones, scene, bpy.context, timing.fps, keyed)
    notes.append(
        f"the motion comes from {', '.join(reasons)}, not only keys: {len(tracks)} DoF"
        f"{'s' if len(tracks) != 1 else ''} baked from the evaluated pose, one smooth (Hermite) Bezier "
        f"piece per frame"
    )
    return tracks


def export_clip(rig_ob: Any, plan: RigPlan, scene: Any, name: str) -> tuple[dict[str, Any], list[str]]:
    """The rig's animation as a nutty-clip/1 document, and notes for the report: the active action's
    keys converted, or (NLA strips, constraints, IK, other drivers) the evaluated pose baked
    (bake.py). ExportError says why not."""
    from .rig import fcurves  # (rig imports bpy: only in Blender)

    timing = Timing.of(scene)
    if timing.end <= timing.start:
        raise ExportError(f"the scene's frame range {timing.start:g}-{timing.end:g} is empty")
    curves = [fc for fc in fcurves(rig_ob) if len(fc.keyframe_points)]
    reasons = bake.bake_reasons(rig_ob, curves)
    if not curves and not reasons:
        raise ExportError(f"'{rig_ob.name}' has no keys to export: pose its bones and key them (I) first")
    notes: list[str] = []
    tracks, events = _curve_tracks(rig_ob, plan, curves, timing, notes, baking=bool(reasons))
    if reasons:
        tracks.update(_evaluated_tracks(rig_ob, plan, scene, reasons, notes, set(tracks)))
    if not tracks:
        raise ExportError(
            f"'{rig_ob.name}' has no keys on the robot's DoFs (bones' Y rotation, or its DoF "
            f"properties): nothing to export"
        )
    anchors, marker_events = _marker_items(scene, plan, timing)
    last = max(k["t"] for keys in tracks.values() for k in keys)
    if last > timing.duration + 1e-9:
        notes.append(f"keys after the end frame {timing.end:g}: the clip ends there ({timing.duration:g} s)")
    return _document(rig_ob, plan, name, timing, tracks, anchors, events + marker_events), notes


def _document(
    rig_ob: Any,
    plan: RigPlan,
    name: str,
    timing: Timing,
    tracks: dict[str, Any],
    anchors: dict[str, float],
    events: list[dict[str, Any]],
) -> dict[str, Any]:
    import bpy  # (Blender's module: the export runs in Blender)

    action = rig_ob.animation_data.action if rig_ob.animation_data else None
    return {
        "format": "nutty-clip/1",
        "name": name,
        "robot": plan.robot,
        "duration": round(timing.duration, 12),  # (a whole number of frames at any fps)
        "tracks": tracks,
        "anchors": anchors,
        "events": sorted(events, key=lambda e: e["t"]),
        "source": {
            "tool": "blender",
            "blender": bpy.app.version_string,
            "file": bpy.path.basename(bpy.data.filepath),
            "object": rig_ob.name,
            "action": action.name if action is not None else "",
            "fps": timing.fps,
            "frame_start": timing.start,
            "frame_end": timing.end,
        },
    }


def sample_tracks(rig_ob: Any, plan: RigPlan, timing: Timing) -> dict[str, list[float]]:
    """Every keyed continuous DoF's F-curve evaluated at each frame of the scene's range (what the clip
    holds there: the exported keys), {} when none is keyed. (For a server older than the clip body.)"""
    from .rig import dof_paths, fcurves  # (rig imports bpy: only in Blender)

    paths = dof_paths(rig_ob, plan)
    out: dict[str, list[float]] = {}
    for fc in fcurves(rig_ob):
        dof = paths.get((fc.data_path, fc.array_index))
        if dof is not None and len(fc.keyframe_points) and not fc.mute:
            out[dof] = [_r(fc.evaluate(f)) for f in timing.frames]
    return out
