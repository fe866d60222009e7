"""The steps of `import_clip`: options checked, the file read and its channels checked (and
repaired, skipped, shifted to start at 0), axes chosen, channels mapped to DoF tracks, the clip
document built and validated against the robot, the report, and the trajectory-helper's analysis
of the limits (with `fit_limits`, the uniform slow-down applied).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from backend.engine.clips import CLIP_FORMAT, Clip, ClipError, compile_clip
from backend.importers.bad_data import check_times, check_values, drop_first_frames
from backend.importers.clip_warnings import first_frame_warning
from backend.importers.keys import round_key
from backend.importers.limits import analyse_clip, scale_clip_time
from backend.importers.mapping import (
    ClipImportError,
    MappingSpec,
    SourceChannel,
    check_mapping,
    load_mapping,
    parse_mapping,
)
from backend.importers.report import build_report
from backend.importers.rotations import RotationError, axis_conversion
from backend.importers.sources import IMPORTERS, read_channels
from backend.importers.tracks import TrackOptions, map_channels

FILL_MODES = ("hold", "linear")
MAX_DURATION = 3600.0  # s: longer sources are almost certainly broken times (and would not fit in memory)
MAX_MESSAGE = 600  # characters of a downstream error kept in a message


def run_import(
    path: str | Path,
    emb,
    mapping: str | Path | dict | MappingSpec | None = None,
    *,
    name: str | None = None,
    animation: str | int | None = None,
    tolerance: float = 1e-3,
    interp: str | None = None,
    fmt: str | None = None,
    up: str | None = None,
    forward: str = "x",
    rest_frame: int | None = None,
    fill: str | None = None,
    max_gap: int = 10,
    skip_frames: int = 0,
    swing_warn: float = 5.0,
    rate: float = 100.0,
    fit_limits: bool = False,
    analyse: bool = True,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Import an animation file for robot `emb`: (clip document, report). Raises ClipImportError.

    mapping: a mapping file path, a mapping dict (`{"joints": {...}}`) or None.
    animation: glTF animation name or index (default the first).
    tolerance: rad/m; BVH keys (and densely sampled rotations) that linear interpolation reproduces
      within it are dropped (0 keeps every frame).
    interp: for CSV, the keys' interpolation (constant, linear or bezier; default linear).
    up, forward: the source's up axis (y or z; default y for glTF and BVH) and the source axis that
      faces the robot's +X (default x).
    rest_frame: BVH: the frame that is the rest pose (default: the OFFSET pose).
    fill: "hold" or "linear" repairs gaps of at most `max_gap` non-finite samples (default: error).
    skip_frames: drop the source's first N frames (distinct key times).
    swing_warn: degrees of dropped rotation above which a channel gets a warning.
    rate: Hz at which the trajectory-helper samples the clip; fit_limits: slow the clip down
      uniformly until it is within the velocity, acceleration and jerk limits.
    """
    check_options(
        tolerance=tolerance,
        interp=interp,
        fill=fill,
        max_gap=max_gap,
        skip_frames=skip_frames,
        rest_frame=rest_frame,
        swing_warn=swing_warn,
        rate=rate,
    )
    spec = mapping_spec(mapping)
    path = Path(path)
    wanted = frozenset(spec.joints) if spec is not None else frozenset()
    kind, channels, info, notes = read_channels(
        path, fmt, animation, rest_frame=rest_frame, fill=fill, max_gap=max_gap, wanted=wanted
    )
    if not channels:
        raise ClipImportError(f"'{path}' has no animated channels")
    where = f"{IMPORTERS[kind].label} '{path.name}'"
    channels, shift, end, filled = prepare_channels(channels, where, fill, max_gap, skip_frames, notes)
    conv, conversion = source_axes(kind, up, forward, notes)
    if spec is not None:
        check_mapping(spec, channels, emb, path.name)
    opts = TrackOptions(
        conv=conv,
        conversion=conversion,
        shift=shift,
        tolerance=tolerance,
        interp=interp if "interp" in IMPORTERS[kind].options else None,
        swing_warn=swing_warn,
    )
    result = map_tracks(channels, emb, spec, opts, path.name, skip_frames)
    doc = clip_document(path, kind, info, emb, result.tracks, end, name)
    report = build_report(path, kind, emb, doc, info, conversion, result, filled, notes)
    if analyse:
        report["limits"] = analyse_limits(doc, emb, rate, fit_limits, report)
    return doc, report


def map_tracks(
    channels: list[SourceChannel],
    emb,
    spec: MappingSpec | None,
    opts: TrackOptions,
    file_name: str,
    skip_frames: int,
):
    """The channels mapped to DoF tracks (`map_channels`), with a warning when the first frame jumps
    (a T-pose or rest frame at the start); a ClipImportError naming why when no channel maps to a DoF."""
    result = map_channels(channels, emb, spec, opts)
    if not result.tracks:
        why = "; ".join(f"{u['source']}: {u['reason']}" for u in result.unmapped[:8])
        raise ClipImportError(
            short(f"no channel of '{file_name}' maps to a DoF of robot '{emb.name}' ({why})")
        )
    jump = first_frame_warning(result.first_frames, emb, skip_frames, opts.conv)
    if jump:
        result.warnings.append(jump)
    return result


def check_options(
    *,
    tolerance: float,
    interp: str | None,
    fill: str | None,
    max_gap: int,
    skip_frames: int,
    rest_frame: int | None,
    swing_warn: float,
    rate: float,
) -> None:
    """The options' ranges (see `run_import`); the first one out of range is a ClipImportError."""
    if tolerance < 0 or not math.isfinite(tolerance):
        raise ClipImportError(f"tolerance must be a finite number >= 0, got {tolerance}")
    if interp is not None and interp not in ("constant", "linear", "bezier"):
        raise ClipImportError(f"interp must be constant, linear or bezier, got '{interp}'")
    if fill is not None and fill not in FILL_MODES:
        raise ClipImportError(f"fill must be hold or linear, got '{fill}'")
    if not (isinstance(max_gap, int) and max_gap >= 1):
        raise ClipImportError(f"max_gap must be a whole number >= 1, got {max_gap}")
    if not (isinstance(skip_frames, int) and skip_frames >= 0):
        raise ClipImportError(f"skip_frames must be a whole number >= 0, got {skip_frames}")
    if rest_frame is not None and not (isinstance(rest_frame, int) and rest_frame >= 0):
        raise ClipImportError(f"rest_frame must be a frame index >= 0, got {rest_frame}")
    if not (math.isfinite(swing_warn) and swing_warn >= 0):
        raise ClipImportError(f"swing_warn must be a finite number of degrees >= 0, got {swing_warn}")
    if not (math.isfinite(rate) and 1.0 <= rate <= 10000.0):
        raise ClipImportError(f"rate must be a number of Hz in [1, 10000], got {rate}")


def mapping_spec(mapping: str | Path | dict | MappingSpec | None) -> MappingSpec | None:
    """A mapping given as a file path, a dict or a parsed spec (None: map by names)."""
    if mapping is None or isinstance(mapping, MappingSpec):
        return mapping
    if isinstance(mapping, dict):
        return parse_mapping(mapping)
    return load_mapping(mapping)


def prepare_channels(
    channels: list[SourceChannel],
    where: str,
    fill: str | None,
    max_gap: int,
    skip_frames: int,
    notes: list[str],
) -> tuple[list[SourceChannel], float, float, dict[str, int]]:
    """Check (or repair) every channel, drop the first `skip_frames` frames and find the time shift
    that starts the clip at 0: (channels, shift s, end s, samples filled per channel)."""
    filled: dict[str, int] = {}
    for ch in channels:
        check_times(ch, where)
        n = check_values(ch, where, fill, max_gap)
        if n:
            filled[ch.label] = n
    if filled:
        per = ", ".join(f"{k} {v}" for k, v in filled.items())
        notes.append(f"--fill {fill}: filled {sum(filled.values())} sample(s) ({per})")
    span = max(float(ch.times[-1]) for ch in channels) - min(float(ch.times[0]) for ch in channels)
    if span > MAX_DURATION:
        raise ClipImportError(
            f"{where}: the keys span {span:.6g} s, more than {MAX_DURATION:g} s; the key times "
            "are probably broken"
        )
    if skip_frames:
        channels = drop_first_frames(channels, skip_frames, notes, where)
    t0 = min(float(ch.times[0]) for ch in channels)
    shift = -t0 if (t0 < 0 or skip_frames) else 0.0
    if t0 < 0:
        notes.append(f"keys start at {t0:g} s; shifted by {shift:g} s so the clip starts at 0")
    end = max(float(ch.times[-1]) for ch in channels) + shift
    return channels, shift, end, filled


def source_axes(
    kind: str, up: str | None, forward: str, notes: list[str]
) -> tuple[np.ndarray, dict[str, str] | None]:
    """(quaternion (x, y, z, w), as in `rotations`, turning source axes into the robot's, {"up", "forward"} or None for a
    format without axes (CSV))."""
    if not IMPORTERS[kind].axes:
        if up not in (None, "z") or forward != "x":
            notes.append(f"--up/--forward do not apply to {IMPORTERS[kind].label} columns; ignored")
        return np.array([0.0, 0.0, 0.0, 1.0]), None
    up = up or "y"
    try:
        conv = axis_conversion(up, forward)
    except RotationError as exc:
        raise ClipImportError(str(exc)) from None
    return conv, {"up": up, "forward": forward}


def clip_document(
    path: Path,
    kind: str,
    info: dict[str, Any],
    emb,
    tracks: dict[str, list[dict[str, Any]]],
    end: float,
    name: str | None,
) -> dict[str, Any]:
    """The `nutty-clip/1` document, validated and compiled against the robot."""

    doc: dict[str, Any] = {
        "format": CLIP_FORMAT,
        "name": (name or path.stem)[:80],
        "description": f"imported from {path.name} ({kind})",
        "robot": emb.name,
        "tracks": tracks,
        "anchors": {},
        "events": [],
        "source": {"file": path.name, "format": kind, **info},
    }
    if end > 0:
        doc["duration"] = round_key(end)
    validate(doc, emb)
    return doc


def analyse_limits(
    doc: dict[str, Any], emb, rate: float, fit_limits: bool, report: dict[str, Any]
) -> dict[str, Any]:
    """The trajectory-helper's report on the clip sampled at `rate` Hz; with `fit_limits` the clip is
    slowed down in place when a uniform slow-down fits (the report's duration and notes follow)."""

    lim = analyse_clip(doc, emb, rate)
    if not fit_limits:
        return lim
    notes = report["notes"]
    s = lim.get("fit_scale")
    if s is None:
        lim["fit_applied"] = None
        notes.append(
            f"--fit-limits: even {lim.get('max_scale', 20):g}x slower the clip breaks the limits; "
            "not slowed down "
            f"(use the NMF preset {lim['nmf']['best']})"
            if lim.get("nmf")
            else "--fit-limits: no slow-down fits the limits; not slowed down"
        )
        return lim
    if s <= 1.0:
        lim["fit_applied"] = 1.0
        return lim
    before = doc.get("duration", 0.0)
    scale_clip_time(doc, s)
    validate(doc, emb)
    after = analyse_clip(doc, emb, rate, suggest=False)
    after["fit_applied"] = s
    after["before"] = {"dofs": lim["dofs"], "fit_scale": s, "nmf": lim["nmf"]}
    report["duration"] = float(doc.get("duration", 0.0))
    notes.append(
        f"--fit-limits: slowed down {s:.3g}x ({before:g} s -> {doc.get('duration', 0.0):g} s) "
        "so every DoF is within its velocity, acceleration and jerk limits"
    )
    return after


def validate(doc: dict[str, Any], emb) -> None:
    """The clip must validate and compile for the robot; otherwise a short ClipImportError."""

    try:
        Clip.model_validate(doc)  # the compact document is written as is (no defaults spelled out)
        compile_clip(doc, emb)
    except (ClipError, ValueError) as exc:
        raise ClipImportError(short(f"the imported clip does not fit robot '{emb.name}': {exc}")) from None


def short(msg: str) -> str:
    """At most a few lines: downstream errors can quote whole key lists."""
    lines = msg.splitlines() or [""]
    head = "\n".join(lines[:4])
    if len(head) > MAX_MESSAGE:
        head = head[:MAX_MESSAGE] + " ..."
    elif len(lines) > 4:
        head += "\n  ..."
    return head
