"""Import animation files as `nutty-clip/1` clips: glTF 2.0 (.gltf/.glb), BVH (.bvh) and CSV keys (.csv).

    from backend.importers import import_clip
    doc, report = import_clip("wave.glb", load_embodiment("nutty_desk"), mapping="map.json")

Each importer reads its file into source channels (`mapping.SourceChannel`) that carry their rest
pose; `mapping.resolve_channel` picks the robot DoF(s) of each (mapping file, exact DoF name, joint or
child-link name, then the same ignoring case and separators). A rotation channel then becomes angles:

1. its change from the rest (bind) pose, in the source's world axes: `pre * q * post` (glTF: the
   node's rest rotation, or the skin's inverse bind matrices; BVH: the OFFSET pose or --rest-frame);
2. in the robot's axes: conjugated by the up/forward conversion (`rotations.axis_conversion`; glTF
   and BVH are +Y up, --up z for files already +Z up; --forward names the source axis that faces
   the robot's +X);
3. reduced to the twist about the DoF's URDF axis in the robot's frame at rest (one DoF), or split
   into angles about two or three DoFs' axes in the listed order (`rotations.davenport`).
The rotation about other axes that this drops (the *swing*) is reported per channel, max and RMS;
above `swing_warn` degrees it is a warning suggesting the channel's principal axis.

Keys: glTF STEP -> constant keys; sparse LINEAR keys -> linear keys (segments whose slerp is not
linear in the angle are sampled densely); *samples* (BVH frames, LINEAR keys at >= 20 Hz as exporters
write them) -> smooth bezier keys through them (`hermite_keys`: the cubic Hermite with the samples'
own slopes, exact at the kept samples, dropping those it reproduces within `tolerance`);
CUBICSPLINE rotations -> sampled densely, then smooth keys keeping the original keys; CUBICSPLINE
scalars/translations -> bezier keys with free handles from the Hermite tangents (right = [dt/3,
out*dt/3], left = [-dt_prev/3, -in*dt_prev/3]), exactly the same curve; CSV -> linear keys (or
`interp`), option names for enum DoFs. Values outside a DoF's limits are clamped.

Bad data (NaN/inf in a header, a frame, a quaternion) stops the import with one short message naming
the channel and the sample (index and time), unless `fill` repairs gaps of up to `max_gap` samples.
After clamping, the trajectory-helper (`limits.analyse_clip`) counts per DoF the samples over the
velocity, acceleration and jerk limits and says what the clip would need (`fit_limits` applies the
slow-down factor). The clip is validated and compiled against the robot before it is returned.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from backend.importers.mapping import (ChannelMap, ClipImportError, MappingSpec, SourceChannel, check_mapping,
                                       dof_axis, load_mapping, parse_mapping, resolve_channel)
from backend.importers.rotations import (RotationError, axis_conversion, davenport, hemisphere, principal_axis,
                                         quat_angle, quat_conj, quat_mul, quat_normalise, slerp, swing_twist,
                                         twist_angle)

__all__ = ["ClipImportError", "FORMATS", "SourceChannel", "decimate", "detect_format", "format_report", "hermite_keys",
           "import_clip", "read_channels", "swing_twist", "twist_angle"]

FORMATS = {".gltf": "gltf", ".glb": "gltf", ".bvh": "bvh", ".csv": "csv"}
FILL_MODES = ("hold", "linear")
MAX_DURATION = 3600.0  # s: longer sources are almost certainly broken times (and would not fit in memory)
MAX_MESSAGE = 600  # characters of a downstream error kept in a message


def detect_format(path: str | Path, fmt: str | None = None) -> str:
    if fmt:
        fmt = fmt.lower()
        if fmt not in set(FORMATS.values()):
            raise ClipImportError(f"unknown format '{fmt}' (one of {sorted(set(FORMATS.values()))})")
        return fmt
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ClipImportError(f"unknown format for '{path}': '{suffix or '(no extension)'}' "
                              f"(supported: {', '.join(sorted(FORMATS))})")
    return FORMATS[suffix]


def read_channels(path: str | Path, fmt: str | None = None, animation: str | int | None = None, *,
                  rest_frame: int | None = None, fill: str | None = None, max_gap: int = 10
                  ) -> tuple[str, list[SourceChannel], dict[str, Any], list[str]]:
    """(format, channels, source info, notes) of a file."""
    path = Path(path)
    kind = detect_format(path, fmt)
    if not path.is_file():
        raise ClipImportError(f"no such file: '{path}'")
    notes: list[str]
    try:
        if kind == "gltf":
            from backend.importers.gltf import read_gltf

            channels, info, notes = read_gltf(path, animation)
        elif kind == "bvh":
            from backend.importers.bvh import read_bvh

            channels, info, notes = read_bvh(path, rest_frame=rest_frame, fill=fill, max_gap=max_gap)
        else:
            from backend.importers.csv_clip import read_csv

            channels, info, notes = read_csv(path, fill=fill)
    except ClipImportError:
        raise
    except (AttributeError, TypeError, IndexError, KeyError, ValueError, OverflowError) as exc:
        # a structure no check above expected (e.g. a glTF object where the schema wants a number)
        raise ClipImportError(f"{kind} '{path.name}': malformed file ({type(exc).__name__}: "
                              f"{str(exc).splitlines()[0][:160] if str(exc) else ''})") from None
    if animation not in (None, "") and kind != "gltf":
        notes.append("--animation only applies to glTF files; ignored")
    if rest_frame is not None and kind != "bvh":
        notes.append("--rest-frame only applies to BVH files; ignored")
    return kind, channels, info, notes


def import_clip(path: str | Path, emb, mapping: str | Path | dict | MappingSpec | None = None, **options: Any
                ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Import an animation file for robot `emb`: (clip document, report). Raises ClipImportError.
    Options: see `_import_clip`. Absurd numbers in a file end in a ClipImportError, not in numpy warnings."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        return _import_clip(path, emb, mapping, **options)


def _import_clip(path: str | Path, emb, mapping: str | Path | dict | MappingSpec | None = None, *,
                name: str | None = None, animation: str | int | None = None, tolerance: float = 1e-3,
                interp: str | None = None, fmt: str | None = None, up: str | None = None, forward: str = "x",
                rest_frame: int | None = None, fill: str | None = None, max_gap: int = 10,
                skip_frames: int = 0, swing_warn: float = 5.0, rate: float = 100.0,
                fit_limits: bool = False, analyse: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
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
    from backend.engine.clips import CLIP_FORMAT, Clip, ClipError, compile_clip

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
    spec: MappingSpec | None
    if mapping is None or isinstance(mapping, MappingSpec):
        spec = mapping
    elif isinstance(mapping, dict):
        spec = parse_mapping(mapping)
    else:
        spec = load_mapping(mapping)
    path = Path(path)
    kind, channels, info, notes = read_channels(path, fmt, animation, rest_frame=rest_frame, fill=fill,
                                                max_gap=max_gap)
    warnings: list[dict[str, Any]] = []
    if not channels:
        raise ClipImportError(f"'{path}' has no animated channels")
    where = f"{kind.upper() if kind != 'gltf' else 'glTF'} '{path.name}'"
    filled: dict[str, int] = {}
    for ch in channels:
        t = np.asarray(ch.times, dtype=float)
        if len(t) == 0 or not np.all(np.isfinite(t)):
            raise ClipImportError(f"{where}: {ch.label}: no key times, or times that are not finite numbers")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise ClipImportError(f"{where}: {ch.label}: {ch.unit} {k} (t = {t[k]:g} s): key times must increase "
                                  f"strictly ({t[k - 1]:g} then {t[k]:g})")
        n = _check_values(ch, where, fill, max_gap)
        if n:
            filled[ch.label] = n
    if filled:
        per = ", ".join(f"{k} {v}" for k, v in filled.items())
        notes.append(f"--fill {fill}: filled {sum(filled.values())} sample(s) ({per})")
    span = max(float(ch.times[-1]) for ch in channels) - min(float(ch.times[0]) for ch in channels)
    if span > MAX_DURATION:
        raise ClipImportError(f"{where}: the keys span {span:.6g} s, more than {MAX_DURATION:g} s; the key times "
                              "are probably broken")
    if skip_frames:
        channels = _skip(channels, skip_frames, notes, where)
    t0 = min(float(ch.times[0]) for ch in channels)
    shift = -t0 if (t0 < 0 or skip_frames) else 0.0
    if t0 < 0:
        notes.append(f"keys start at {t0:g} s; shifted by {shift:g} s so the clip starts at 0")
    end = max(float(ch.times[-1]) for ch in channels) + shift

    if kind == "csv":
        if up not in (None, "z") or forward != "x":
            notes.append("--up/--forward do not apply to CSV columns; ignored")
        conv = np.array([0.0, 0.0, 0.0, 1.0])
        conversion = None
    else:
        up = up or "y"
        try:
            conv = axis_conversion(up, forward)
        except RotationError as exc:
            raise ClipImportError(str(exc)) from None
        conversion = {"up": up, "forward": forward}
    if spec is not None:
        check_mapping(spec, channels, emb, path.name)

    # resolve: the mapping file's entries first, then names
    resolved: list[tuple[SourceChannel, ChannelMap | None, str]] = []
    for ch in channels:
        cmap, reason = resolve_channel(ch, emb, spec)
        resolved.append((ch, cmap, reason))
    order = sorted(range(len(resolved)), key=lambda i: (resolved[i][1] is None or resolved[i][1].key is None, i))
    driven_by: dict[str, str] = {}
    tracks: dict[str, list[dict[str, Any]]] = {}
    mapped: list[dict[str, Any]] = []
    unmapped: list[dict[str, Any]] = []
    clamped: dict[str, int] = {}
    first_frames: list[tuple[str, float, float, float, SourceChannel]] = []
    entries: dict[int, list[dict[str, Any]]] = {}
    for i in order:
        ch, cmap, reason = resolved[i]
        if cmap is not None:
            taken = [t.dof for t in cmap.targets if t.dof in driven_by]
            if taken:
                cmap, reason = None, f"DoF '{taken[0]}' is already driven by '{driven_by[taken[0]]}'"
        if cmap is None:
            entries[i] = [{"source": ch.label, "kind": ch.kind, "reason": reason, "_unmapped": True}]
            continue
        try:
            conv_out = _convert(ch, cmap, emb, conv, shift, tolerance, interp if kind == "csv" else None)
        except ClipImportError as exc:
            entries[i] = [{"source": ch.label, "kind": ch.kind, "reason": str(exc), "_unmapped": True}]
            continue
        rows = []
        for target, (keys, how_keys, raw_t, raw_v, n_pre) in zip(cmap.targets, conv_out["tracks"]):
            n_clamped = n_pre + _clamp(keys, emb.dof(target.dof))
            if n_clamped:
                clamped[target.dof] = n_clamped
            tracks[target.dof] = keys
            driven_by[target.dof] = ch.label
            entry: dict[str, Any] = {"source": ch.label, "kind": ch.kind, "dof": target.dof, "how": cmap.how,
                                     "interp": ch.interp, "keys": len(keys), "source_keys": len(ch.times),
                                     "conversion": how_keys}
            if target.axis is not None:
                entry["axis"] = [round(float(x), 6) for x in target.axis]
            if target.scale != 1.0 or target.offset != 0.0:
                entry["scale"], entry["offset"] = target.scale, target.offset
            if ch.detail:
                entry["detail"] = ch.detail
            if ch.rest_note and ch.kind in ("rotation", "translation"):
                entry["rest"] = ch.rest_note
            if "swing" in conv_out:
                entry.update(conv_out["swing"])
            rows.append(entry)
            if len(raw_t) >= 3 and _is_sampled(ch):  # frames of a motion, not an animator's keys
                first_frames.append((target.dof, float(raw_t[1] - raw_t[0]), float(raw_v[1] - raw_v[0]),
                                     float(np.max(np.abs(np.diff(raw_v[1:]))) if len(raw_v) > 2 else 0.0), ch))
        entries[i] = rows
        sw = conv_out.get("swing")
        if sw and sw["swing_max_deg"] > swing_warn:
            warnings.append(_swing_warning(ch, cmap, sw, emb, swing_warn, conversion))
    for i in range(len(resolved)):
        for e in entries.get(i, []):
            if e.pop("_unmapped", False):
                unmapped.append(e)
            else:
                mapped.append(e)
    if not tracks:
        why = "; ".join(f"{u['source']}: {u['reason']}" for u in unmapped[:8])
        raise ClipImportError(_short(f"no channel of '{path.name}' maps to a DoF of robot '{emb.name}' ({why})"))
    jump = _first_frame_warning(first_frames, emb, skip_frames, conv)
    if jump:
        warnings.append(jump)

    source = {"file": path.name, "format": kind, **info}
    doc: dict[str, Any] = {
        "format": CLIP_FORMAT,
        "name": (name or path.stem)[:80],
        "description": f"imported from {path.name} ({kind})",
        "robot": emb.name,
        "tracks": tracks,
        "anchors": {},
        "events": [],
        "source": source,
    }
    if end > 0:
        doc["duration"] = _r(end)
    _validate(doc, emb, Clip, ClipError, compile_clip)
    report: dict[str, Any] = {
        "file": str(path),
        "format": kind,
        "robot": emb.name,
        "clip": doc["name"],
        **{k: v for k, v in info.items()},
        "conversion": conversion,
        "mapped": mapped,
        "unmapped": unmapped,
        "clamped": clamped,
        "clamped_total": sum(clamped.values()),
        "tracks": len(tracks),
        "keys": sum(len(k) for k in tracks.values()),
        "duration": float(doc.get("duration", 0.0)),
        "filled": {"samples": sum(filled.values()), "channels": filled} if filled else None,
        "warnings": warnings,
        "notes": notes,
    }
    if analyse:
        from backend.importers.limits import analyse_clip, scale_clip_time

        lim = analyse_clip(doc, emb, rate)
        if fit_limits:
            s = lim.get("fit_scale")
            if s is None:
                lim["fit_applied"] = None
                notes.append(f"--fit-limits: even {lim.get('max_scale', 20):g}x slower the clip breaks the limits; "
                             "not slowed down "
                             f"(use the NMF preset {lim['nmf']['best']})" if lim.get("nmf") else
                             "--fit-limits: no slow-down fits the limits; not slowed down")
            elif s > 1.0:
                before = doc.get("duration", 0.0)
                scale_clip_time(doc, s)
                _validate(doc, emb, Clip, ClipError, compile_clip)
                after = analyse_clip(doc, emb, rate, suggest=False)
                after["fit_applied"] = s
                after["before"] = {"dofs": lim["dofs"], "fit_scale": s, "nmf": lim["nmf"]}
                lim = after
                report["duration"] = float(doc.get("duration", 0.0))
                notes.append(f"--fit-limits: slowed down {s:.3g}x ({before:g} s -> {doc.get('duration', 0.0):g} s) "
                             "so every DoF is within its velocity, acceleration and jerk limits")
            else:
                lim["fit_applied"] = 1.0
        report["limits"] = lim
    return doc, report


def _validate(doc, emb, Clip, ClipError, compile_clip) -> None:
    try:
        Clip.model_validate(doc)  # the compact document is written as is (no defaults spelled out)
        compile_clip(doc, emb)
    except (ClipError, ValueError) as exc:
        raise ClipImportError(_short(f"the imported clip does not fit robot '{emb.name}': {exc}")) from None


def _short(msg: str) -> str:
    """At most a few lines: downstream errors can quote whole key lists."""
    lines = msg.splitlines() or [""]
    head = "\n".join(lines[:4])
    if len(head) > MAX_MESSAGE:
        head = head[:MAX_MESSAGE] + " ..."
    elif len(lines) > 4:
        head += "\n  ..."
    return head


# --------------------------------------------------------------------------------------------------
# Bad data
# --------------------------------------------------------------------------------------------------


def _check_values(ch: SourceChannel, where: str, fill: str | None, max_gap: int) -> int:
    """Non-finite values (or zero-length quaternions) in a numeric channel: an error naming the first
    sample, or with `fill` the number of samples repaired (gaps of at most `max_gap`)."""
    if not isinstance(ch.values, np.ndarray) or ch.values.dtype == object:
        return 0
    v = np.asarray(ch.values, dtype=float)
    v2 = v.reshape(len(v), -1)
    bad = ~np.all(np.isfinite(v2), axis=1)
    what = "is not finite"
    if ch.kind == "rotation":
        zero = np.zeros(len(v2), dtype=bool)
        with np.errstate(over="ignore", invalid="ignore"):
            norms = np.linalg.norm(v2[~bad], axis=1)
        bad[~bad] = ~np.isfinite(norms)
        zero[~bad] = np.linalg.norm(v2[~bad], axis=1) < 1e-9
        if zero.any() and not bad[zero].any():
            what = "has length 0 (not a rotation)"
        bad |= zero
    tan_bad = np.zeros(len(v2), dtype=bool)
    for tan in (ch.in_tangents, ch.out_tangents):
        if tan is not None:
            tan_bad |= ~np.all(np.isfinite(np.asarray(tan, dtype=float).reshape(len(v2), -1)), axis=1)
    if not bad.any() and not tan_bad.any():
        return 0
    t = np.asarray(ch.times, dtype=float)
    k = int(np.flatnonzero(bad | tan_bad)[0])
    shown = np.round(v2[k], 6).tolist()
    if fill is None or (tan_bad.any() and ch.interp == "CUBICSPLINE"):
        part = "its spline tangent" if (tan_bad[k] and not bad[k]) else f"value {shown}"
        n = int((bad | tan_bad).sum())
        more = f" ({n} {ch.unit}s have such values)" if n > 1 else ""
        hint = "" if fill is not None else f"\n  --fill hold|linear repairs gaps of up to {max_gap} {ch.unit}s"
        raise ClipImportError(f"{where}: {ch.unit} {k} (t = {t[k]:g} s): {ch.label}: {part} "
                              f"{what if not tan_bad[k] or bad[k] else 'is not finite'}{more}{hint}")
    good = np.flatnonzero(~bad)
    if good.size == 0:
        raise ClipImportError(f"{where}: {ch.label}: no {ch.unit} has a usable value; nothing to fill from")
    d = np.diff(np.concatenate([[0], bad.astype(np.int8), [0]]))
    runs = list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))
    for a, b in runs:
        if b - a > max_gap:
            raise ClipImportError(f"{where}: {ch.unit}s {a}-{b - 1} (t = {t[a]:g}-{t[b - 1]:g} s): {ch.label}: "
                                  f"a gap of {b - a} unusable {ch.unit}s, longer than --max-gap {max_gap}")
    out = v2.copy()
    for a, b in runs:
        if a == 0 or b == len(out) or fill == "hold":
            out[a:b] = out[a - 1] if a > 0 else out[b]
            continue
        u = (t[a:b] - t[a - 1]) / (t[b] - t[a - 1])
        if ch.kind == "rotation":
            out[a:b] = slerp(np.broadcast_to(out[a - 1], (b - a, 4)), np.broadcast_to(out[b], (b - a, 4)), u)
        else:
            out[a:b] = out[a - 1] + u[:, None] * (out[b] - out[a - 1])
    ch.values = out.reshape(v.shape)
    return int(bad.sum())


def _skip(channels: list[SourceChannel], n: int, notes: list[str], where: str) -> list[SourceChannel]:
    """Drop the first `n` frames (distinct key times over all channels)."""
    times = np.unique(np.concatenate([np.asarray(ch.times, dtype=float) for ch in channels]))
    if n >= len(times):
        raise ClipImportError(f"{where}: --skip-frames {n}: the file has only {len(times)} distinct key time(s)")
    cut = float(times[n])
    for ch in channels:
        t = np.asarray(ch.times, dtype=float)
        keep = t >= cut - 1e-12
        if not keep.any():  # a channel that ends before the cut holds its last value from there
            keep[-1] = True
            t = t.copy()
            t[-1] = cut
        ch.times = t[keep]
        if isinstance(ch.values, np.ndarray):
            ch.values = ch.values[keep]
        else:
            ch.values = [v for v, k in zip(ch.values, keep) if k]
        if ch.in_tangents is not None:
            ch.in_tangents = ch.in_tangents[keep]
            ch.out_tangents = ch.out_tangents[keep]
    notes.append(f"--skip-frames {n}: dropped the keys before t = {cut:g} s; the clip starts there")
    return channels


# --------------------------------------------------------------------------------------------------
# Channel -> keys
# --------------------------------------------------------------------------------------------------


SAMPLED_DT = 0.05  # s: LINEAR keys at least this dense (20 Hz) are samples of a motion, not poses


def _is_sampled(ch: SourceChannel) -> bool:
    """Frames of mocap, or keys an exporter sampled at a frame rate: a smooth curve goes through them."""
    if ch.decimate:
        return True
    t = np.asarray(ch.times, dtype=float)
    return ch.interp == "LINEAR" and len(t) >= 4 and float(np.median(np.diff(t))) <= SAMPLED_DT


def _make_keys(ts: np.ndarray, vals: np.ndarray, mode: str, tol: float, dof, how: str,
               force: np.ndarray | None = None) -> tuple[list[dict[str, Any]], str, int]:
    """Keys of one track: mode constant | linear | linear-decimated | smooth (Hermite keys through the
    samples) | a CSV --interp. Smooth keys are fitted to the samples clamped to the DoF's limits."""
    if mode == "smooth":
        n_cl = 0
        if dof.type.value == "continuous":
            clipped = np.clip(vals, dof.min, dof.max)
            n_cl = int(np.count_nonzero(clipped != vals))
            vals = clipped
        keys = hermite_keys(ts, vals, tol, force)
        within = f" within {tol:g}" if tol > 0 else ""
        return keys, how + f", smooth (bezier) keys through the samples{within}", n_cl
    if mode == "constant":
        return _keys(ts, vals, "constant"), how + ", constant keys", 0
    if mode == "linear-decimated" and tol > 0:
        t_keep, v_keep = decimate(ts, vals, tol)
        dropped = len(ts) - len(t_keep)
        return _keys(t_keep, v_keep, "linear"), how + f", linear keys ({dropped} dropped within {tol:g})", 0
    if mode in ("linear", "linear-decimated"):
        return _keys(ts, vals, "linear"), how + ", linear keys", 0
    return _keys(ts, vals, mode), how + f", {mode} keys", 0


def _convert(ch: SourceChannel, cmap: ChannelMap, emb, conv: np.ndarray, shift: float, tol: float,
             interp: str | None) -> dict[str, Any]:
    """{"tracks": [(keys, how, sample times, sample values, clamped samples) per target], "swing": {...}}."""
    times = np.asarray(ch.times, dtype=float) + shift
    if ch.kind == "rotation":
        return _convert_rotation(ch, cmap, emb, conv, times, tol)
    target = cmap.targets[0]
    sc, off = target.scale, target.offset
    dof = emb.dof(target.dof)
    if ch.kind == "scalar" and not isinstance(ch.values, np.ndarray):
        # CSV column with option names (enum DoFs)
        if dof.type.value != "enum":
            raise ClipImportError(f"DoF '{target.dof}' is {dof.type.value} but the column has non-numeric "
                                  f"values ({next(v for v in ch.values if isinstance(v, str))!r})")
        keys = [{"t": float(t), "v": v if isinstance(v, str) else float(v), "interp": "constant"}
                for t, v in zip(times, ch.values)]
        return {"tracks": [(keys, "option names, constant keys", np.zeros(0), np.zeros(0), 0)]}
    if ch.kind == "translation":
        p = np.asarray(ch.values, dtype=float)
        rest = p[0] if ch.rest is None else np.asarray(ch.rest, dtype=float)
        rot = _qrot(quat_mul(conv, ch.pre))
        axis = target.axis
        vals = (p - rest) @ rot.T @ axis * sc + off
        how = "change from rest in robot axes, projected onto the axis"
        if ch.interp == "CUBICSPLINE":
            a = np.asarray(ch.in_tangents, dtype=float) @ rot.T @ axis * sc
            b = np.asarray(ch.out_tangents, dtype=float) @ rot.T @ axis * sc
            return {"tracks": [(_bezier_keys(times, vals, a, b), how + ", bezier keys from the spline tangents",
                                times, vals, 0)]}
    else:
        vals = np.asarray(ch.values, dtype=float) * sc + off
        how = "value"
        if ch.interp == "CUBICSPLINE":
            a = np.asarray(ch.in_tangents, dtype=float) * sc
            b = np.asarray(ch.out_tangents, dtype=float) * sc
            return {"tracks": [(_bezier_keys(times, vals, a, b), "bezier keys from the spline tangents", times,
                                vals, 0)]}
    if ch.interp == "STEP":
        mode = "constant"
    elif interp is not None:
        mode = interp
    elif _is_sampled(ch) and ch.kind != "scalar" or ch.decimate:
        mode = "smooth"
    else:
        mode = "linear"
    keys, how, n_cl = _make_keys(times, vals, mode, tol, dof, how)
    return {"tracks": [(keys, how, times, vals, n_cl)]}


def _qrot(q: np.ndarray) -> np.ndarray:
    from backend.importers.rotations import quat_to_matrix

    return quat_to_matrix(q)


def _convert_rotation(ch: SourceChannel, cmap: ChannelMap, emb, conv: np.ndarray, times: np.ndarray,
                      tol: float) -> dict[str, Any]:
    pre = quat_mul(conv, ch.pre)
    post = quat_mul(ch.post, quat_conj(conv))
    targets = cmap.targets
    axes = [t.axis for t in targets]

    def robot(q: np.ndarray) -> np.ndarray:
        return hemisphere(quat_mul(quat_mul(pre, q), post))

    def angles(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if len(axes) == 1:
            ang = twist_angle(d, axes[0])[:, None]
            sw, _ = swing_twist(d, axes[0])
            return ang, quat_angle(sw)
        try:
            return davenport(d, axes)
        except RotationError as exc:
            raise ClipImportError(str(exc)) from None

    q = np.asarray(ch.values, dtype=float)
    sampled = _is_sampled(ch)
    force = None
    if ch.interp == "CUBICSPLINE":
        ts, qs = _sample_hermite(times, q, np.asarray(ch.in_tangents), np.asarray(ch.out_tangents))
        qs = quat_normalise(qs)
        force = np.flatnonzero(np.isin(ts, times))  # the animator's own keys stay keys
        mode, first_ok = "smooth", False
        what = f"spline rotation sampled at {len(ts)} points"
    elif ch.interp == "STEP":
        ts, qs, what, mode, first_ok = times, q, "", "constant", True
    elif sampled:
        ts, qs, what, mode, first_ok = times, q, "", "smooth", True
    elif len(times) > 1:
        ts, qs, n_dense = _densify_slerp(times, q, lambda d: angles(robot(d))[0], tol)
        what = f"{n_dense} segment(s) sampled densely" if n_dense else ""
        mode = "linear-decimated" if n_dense else "linear"
        first_ok = not n_dense
        tol = tol / 4
    else:
        ts, qs, what, mode, first_ok = times, q, "", "linear", True
    d = robot(qs)
    ang, swing = angles(d)
    if len(axes) == 1:
        how = "twist about the axis (robot frame, relative to rest)"
    else:
        how = "angle " + " then ".join(f"{t.dof}" for t in targets) + " (decomposed in that order, robot frame)"
    if what:
        how += f", {what}"
    out_tracks = []
    for j, target in enumerate(targets):
        vals = ang[:, j] * target.scale + target.offset
        keys, h, n_cl = _make_keys(ts, vals, mode, tol, emb.dof(target.dof), how, force)
        out_tracks.append((keys, h, ts if first_ok else ts[:0], vals if first_ok else vals[:0], n_cl))
    axis, share = principal_axis(d)
    swing_deg = np.degrees(swing)
    sw = {"swing_max_deg": round(float(swing_deg.max(initial=0.0)), 4),
          "swing_rms_deg": round(float(np.sqrt(np.mean(swing_deg ** 2))) if len(swing_deg) else 0.0, 4),
          "principal_axis": [round(float(x), 4) + 0.0 for x in axis], "principal_share": round(share, 4)}
    return {"tracks": out_tracks, "swing": sw}


def hermite_keys(times: np.ndarray, vals: np.ndarray, tol: float, force: np.ndarray | None = None
                 ) -> list[dict[str, Any]]:
    """Samples -> bezier keys (free handles, a third of each segment) of the cubic Hermite curve through
    them with the samples' own slopes (central differences): smooth (continuous velocity) and exact at
    the kept samples. With tol > 0, samples that the curve between the kept ones reproduces within
    tol are dropped (greedy, like `decimate`); the samples at indices `force` are always kept."""
    t = np.asarray(times, dtype=float)
    v = np.asarray(vals, dtype=float)
    n = len(t)
    if n == 1:
        return _keys(t, v, "linear")
    m = np.gradient(v, t) if n > 2 else np.full(n, (v[1] - v[0]) / (t[1] - t[0]))
    if tol > 0 and n > 2:
        stops = sorted(set([n - 1] + ([] if force is None else [int(k) for k in force if 0 < k < n])))
        keep = [0]
        i = 0
        for stop in stops:
            while i < stop:
                j = i + 1
                while j + 1 <= stop and _hermite_ok(t, v, m, i, j + 1, tol):
                    j += 1
                keep.append(j)
                i = j
        idx = np.array(keep)
    else:
        idx = np.arange(n)
    return _bezier_keys(t[idx], v[idx], m[idx], m[idx])


def _hermite_ok(t: np.ndarray, v: np.ndarray, m: np.ndarray, i: int, j: int, tol: float) -> bool:
    dt = t[j] - t[i]
    s = (t[i + 1:j] - t[i]) / dt
    s2, s3 = s * s, s * s * s
    h = ((2 * s3 - 3 * s2 + 1) * v[i] + (s3 - 2 * s2 + s) * dt * m[i] + (-2 * s3 + 3 * s2) * v[j]
         + (s3 - s2) * dt * m[j])
    return bool(np.all(np.abs(h - v[i + 1:j]) <= tol))


def _densify_slerp(times: np.ndarray, q: np.ndarray, values, tol: float, rate: float = 60.0,
                   min_per_segment: int = 8, min_dt: float = 0.02) -> tuple[np.ndarray, np.ndarray, int]:
    """LINEAR rotation keys -> samples: the keys, plus dense slerp samples in the segments (longer
    than `min_dt`) where the angle of the slerp is not linear in time within tol/4."""
    q = hemisphere(quat_normalise(q))
    dt = np.diff(times)
    long = np.flatnonzero(dt > min_dt)
    if long.size == 0:
        return times, q, 0
    eps = max(tol / 4, 1e-6)
    v_keys = values(q)
    mids = slerp(q[long], q[long + 1], np.full(long.size, 0.5))
    v_mid = values(mids)
    # the keys' values are unwrapped along the keys; bring the midpoints to the same branch
    lin = 0.5 * (v_keys[long] + v_keys[long + 1])
    err = np.abs(((v_mid - lin) + math.pi) % (2 * math.pi) - math.pi).max(axis=1)
    seg = long[err > eps]
    if seg.size == 0:
        return times, q, 0
    ts, qs = [], []
    segset = set(seg.tolist())
    for k in range(len(times) - 1):
        if k in segset:
            m = max(min_per_segment, int(math.ceil(dt[k] * rate)))
            u = np.arange(m) / m
            ts.append(times[k] + u * dt[k])
            qs.append(slerp(np.broadcast_to(q[k], (m, 4)), np.broadcast_to(q[k + 1], (m, 4)), u))
        else:
            ts.append(times[k:k + 1])
            qs.append(q[k:k + 1])
    ts.append(times[-1:])
    qs.append(q[-1:])
    return np.concatenate(ts), np.concatenate(qs), int(seg.size)


def _keys(times: np.ndarray, vals: np.ndarray, interp: str) -> list[dict[str, Any]]:
    return [{"t": _r(t), "v": _r(v), "interp": interp} for t, v in zip(times, vals)]


def _r(x: float) -> float:
    """Key numbers rounded to 1e-10 (far below any joint's resolution) to keep the JSON readable."""
    return round(float(x), 10) + 0.0


def _bezier_keys(times: np.ndarray, vals: np.ndarray, in_t: np.ndarray, out_t: np.ndarray) -> list[dict[str, Any]]:
    """Cubic Hermite (glTF CUBICSPLINE) -> bezier keys with free handles, exactly the same curve."""
    keys = []
    n = len(times)
    for k in range(n):
        dt_prev = times[k] - times[k - 1] if k > 0 else 0.0
        dt_next = times[k + 1] - times[k] if k < n - 1 else 0.0
        keys.append({
            "t": _r(times[k]), "v": _r(vals[k]), "interp": "bezier",
            "left_type": "free", "right_type": "free",
            "left": [_r(-dt_prev / 3.0), _r(-in_t[k] * dt_prev / 3.0)],
            "right": [_r(dt_next / 3.0), _r(out_t[k] * dt_next / 3.0)],
        })
    return keys


def _sample_hermite(times: np.ndarray, q: np.ndarray, in_t: np.ndarray, out_t: np.ndarray,
                    rate: float = 60.0, min_per_segment: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Dense samples of a glTF cubic spline of vectors (the unnormalised quaternion components)."""
    ts, qs = [], []
    for k in range(len(times) - 1):
        dt = times[k + 1] - times[k]
        m = max(min_per_segment, int(math.ceil(dt * rate)))
        s = np.arange(m) / m
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        p = (h00[:, None] * q[k] + (h10 * dt)[:, None] * out_t[k] + h01[:, None] * q[k + 1]
             + (h11 * dt)[:, None] * in_t[k + 1])
        ts.append(times[k] + s * dt)
        qs.append(p)
    ts.append(times[-1:])
    qs.append(q[-1:])
    return np.concatenate(ts), np.concatenate(qs)


def decimate(times: np.ndarray, vals: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Drop keys that linear interpolation between the kept keys reproduces within `tol` (greedy)."""
    times = np.asarray(times, dtype=float)
    vals = np.asarray(vals, dtype=float)
    n = len(times)
    if n <= 2:
        return times, vals
    keep = [0]
    i = 0
    while i < n - 1:
        j = i + 1
        while j + 1 < n:
            cand = j + 1
            mid = slice(i + 1, cand)
            u = (times[mid] - times[i]) / (times[cand] - times[i])
            err = np.abs(vals[i] + u * (vals[cand] - vals[i]) - vals[mid])
            if np.all(err <= tol):
                j = cand
            else:
                break
        keep.append(j)
        i = j
    idx = np.array(keep)
    return times[idx], vals[idx]


def _clamp(keys: list[dict[str, Any]], dof) -> int:
    if dof.type.value != "continuous":
        return 0
    n = 0
    for k in keys:
        v = k["v"]
        c = min(max(v, dof.min), dof.max)
        if c != v:
            n += 1
            k["v"] = c
            if "left" in k:  # flat at the limit
                k["left"][1] = 0.0
                k["right"][1] = 0.0
    return n


# --------------------------------------------------------------------------------------------------
# Warnings
# --------------------------------------------------------------------------------------------------


def _fmt_axis(a: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.3g}" if abs(x) > 5e-4 else "0" for x in a) + "]"


def _other_conversions(axis: np.ndarray, target: np.ndarray, conversion: dict[str, str] | None) -> list[str]:
    """Options (`--forward z`, `--up z`, ...) under which the principal axis `axis` (robot frame under
    the current conversion) would lie along the DoF's axis `target`: the same --up first."""
    if not conversion:
        return []
    from backend.importers.rotations import quat_to_matrix

    up, fwd = conversion["up"], conversion["forward"]
    src = quat_to_matrix(quat_conj(axis_conversion(up, fwd))) @ axis
    out = []
    for u in (up, "z" if up == "y" else "y"):
        for f in ("x", "-x", "y", "-y", "z", "-z"):
            if (u, f) == (up, fwd):
                continue
            try:
                c = quat_to_matrix(axis_conversion(u, f))
            except RotationError:
                continue
            if abs(float((c @ src) @ target)) > 0.9:
                parts = ([f"--up {u}"] if u != up else []) + ([f"--forward {f}"] if f != "x" or u == up else [])
                out.append(" ".join(parts))
        if out:
            break
    return out[:2]


def _swing_warning(ch: SourceChannel, cmap: ChannelMap, sw: dict[str, Any], emb, limit: float,
                   conversion: dict[str, str] | None = None) -> dict[str, Any]:
    axis = np.array(sw["principal_axis"])
    dofs = [t.dof for t in cmap.targets]
    forwards = _other_conversions(axis, cmap.targets[0].axis, conversion) if len(dofs) == 1 else []
    # the robot DoF whose axis is closest to the principal axis
    best, best_dot = None, 0.0
    for d in emb.dofs:
        if d.type.value != "continuous" or d.dimension.value != "stationary":
            continue
        a = dof_axis(emb, d.name)
        if a is None:
            continue
        dot = abs(float(a @ axis))
        if dot > best_dot + 1e-9:
            best, best_dot = d.name, dot
    target = " then ".join(dofs)
    msg = (f"{ch.label} -> {target}: drops up to {sw['swing_max_deg']:.1f} deg (RMS {sw['swing_rms_deg']:.1f} deg) "
           f"of rotation about other axes; the channel turns mostly about {_fmt_axis(axis)} in the robot's frame "
           f"({100 * sw['principal_share']:.0f}% of its motion)")
    if forwards:
        hint = (f"if the source faces or stands another way, {' or '.join(forwards)} turns that axis onto "
                f"{dofs[0]}'s; ")
    else:
        hint = ""
    hint += f'to keep the motion as it is, "axis": {_fmt_axis(axis)} in the mapping file'
    if best is not None and best_dot > 0.9 and best not in dofs:
        hint += f", or map it to '{best}' (whose axis is closest)"
    return {"code": "swing", "channel": ch.label, "dofs": dofs, "message": msg, "hint": hint,
            "swing_max_deg": sw["swing_max_deg"], "swing_rms_deg": sw["swing_rms_deg"],
            "suggested_axis": [round(float(x), 4) + 0.0 for x in axis], "threshold_deg": limit}


def _first_frame_warning(rows: list[tuple[str, float, float, float, SourceChannel]], emb, skipped: int,
                         conv: np.ndarray) -> dict[str, Any] | None:
    """The first frame jumps to the second more than the DoF can move in one frame (and much more than
    any later frame-to-frame step): a T-pose or rest frame at the start."""
    worst = None
    for dof, dt, jump, later, ch in rows:
        if dt <= 0:
            continue
        can = emb.dof(dof).velocity * dt
        if abs(jump) > can and abs(jump) > 3 * later:
            ratio = abs(jump) / can
            if worst is None or ratio > worst[0]:
                worst = (ratio, dof, jump, can, ch)
    if worst is None:
        return None
    _, dof, jump, can, ch = worst
    n_dofs = sum(1 for dof_, dt, j, later, _c in rows
                 if dt > 0 and abs(j) > emb.dof(dof_).velocity * dt and abs(j) > 3 * later)
    rest_like = all(float(quat_angle(quat_mul(quat_mul(c.pre, np.asarray(c.values[0], dtype=float)), c.post)))
                    < math.radians(1.0) for _d, _t, _j, _l, c in rows if c.kind == "rotation")
    kind = "the rest pose (a T-pose)" if rest_like else "a T-pose or rest frame"
    frame = skipped
    msg = (f"the first {ch.unit} ({ch.unit} {frame}) jumps {math.degrees(abs(jump)):.1f} deg to the next on '{dof}' "
           f"(it can move {math.degrees(can):.2f} deg in one {ch.unit}; {n_dofs} DoF(s) jump like this): it looks "
           f"like {kind}")
    return {"code": "first_frame", "channel": ch.label, "dofs": [dof], "message": msg,
            "hint": f"--skip-frames {skipped + 1} drops it"}


# --------------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------------


def format_report(report: dict[str, Any]) -> str:
    """The import report for a person."""
    lines = [f"imported {report['file']} ({report['format']}"
             + (f", animation '{report['animation']}'" if report.get("animation") else "")
             + f") for robot '{report['robot']}': {report['tracks']} track(s), {report['keys']} key(s), "
             f"{report['duration']:g} s"]
    conv = report.get("conversion")
    if conv:
        lines.append(f"axes: source +{conv['up'].lstrip('+')} up and {conv['forward']} forward "
                     "-> robot +Z up, +X forward")
    if report["mapped"]:
        lines.append("mapped:")
        for m in report["mapped"]:
            extra = []
            if "axis" in m:
                extra.append(f"axis {m['axis']}")
            if "scale" in m:
                extra.append(f"scale {m['scale']:g}, offset {m['offset']:g}")
            if "detail" in m:
                extra.append(m["detail"])
            if "rest" in m:
                extra.append(f"rest: {m['rest']}")
            if "swing_max_deg" in m:
                extra.append(f"swing dropped max {m['swing_max_deg']:.2f} deg, RMS {m['swing_rms_deg']:.2f} deg")
            lines.append(f"  {m['source']} -> {m['dof']}  [{m['how']}; {m['interp']}; {m['conversion']}; "
                         f"{m['source_keys']} -> {m['keys']} keys{'; ' + '; '.join(extra) if extra else ''}]")
    if report["unmapped"]:
        lines.append("unmapped:")
        grouped: dict[str, list[tuple[str, str]]] = {}
        for u in report["unmapped"]:
            base = u["source"].rsplit(".", 1)[0] if "." in u["source"] else u["source"]
            template = u["reason"].replace(f"'{base}.", "'<name>.")
            grouped.setdefault(template, []).append((u["source"], u["reason"]))
        for template, items in grouped.items():
            if len(items) <= 2:
                lines.extend(f"  {src}: {reason}" for src, reason in items)
                continue
            names = ", ".join(src for src, _ in items[:6]) + (", ..." if len(items) > 6 else "")
            lines.append(f"  {len(items)} channels ({names}): {template}")
    if report["clamped_total"]:
        per = ", ".join(f"{d} {n}" for d, n in report["clamped"].items())
        lines.append(f"clamped {report['clamped_total']} key value(s) to the DoF limits ({per})")
    lim = report.get("limits")
    if lim:
        lines.extend(_format_limits(lim))
    for note in report["notes"]:
        lines.append(f"note: {note}")
    for w in report.get("warnings", []):
        lines.append(f"warning: {w['message']}")
        if w.get("hint"):
            lines.append(f"  {w['hint']}")
    return "\n".join(lines)


def _format_limits(lim: dict[str, Any]) -> list[str]:
    lines = []
    rows = lim.get("dofs", {})
    over = {d: c for d, c in rows.items() if c["velocity"] or c["acceleration"] or c["jerk"]}
    if not rows:
        return lines
    if not over:
        lines.append("limits: every DoF is within its velocity, acceleration and jerk limits "
                     f"(sampled at {lim['rate']:g} Hz)")
        return lines
    n = next(iter(rows.values()))["samples"]
    lines.append(f"limits (trajectory-helper, {n} samples at {lim['rate']:g} Hz; samples over each limit):")
    for d, c in over.items():
        lines.append(f"  {d}: velocity {c['velocity']} (peak {c['max_velocity']:.3g} / {c['velocity_limit']:g}), "
                     f"acceleration {c['acceleration']} "
                     f"(peak {c['max_acceleration']:.3g} / {c['acceleration_limit']:g}), "
                     f"jerk {c['jerk']} (peak {c['max_jerk']:.3g} / {c['jerk_limit']:g})")
    s = lim.get("fit_scale")
    if s is not None and s > 1:
        lines.append(f"  to fit: play it {s:.3g}x slower (--fit-limits applies that)")
    elif s is None and lim.get("nmf"):
        lines.append(f"  to fit: no slow-down up to {lim.get('max_scale', 20):g}x fits")
    nmf = lim.get("nmf")
    if nmf:
        lines.append(f"  or filter it: NMF preset {nmf['best']} ({nmf['meaning']}) keeps its shape best "
                     f"(RMS {nmf['rms_deg']:.2f} deg, max {nmf['max_deg']:.2f} deg from the clip)")
    return lines
