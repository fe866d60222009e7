"""Import animation files as `nutty-clip/1` clips: glTF 2.0 (.gltf/.glb), BVH (.bvh) and CSV keys (.csv).

    from backend.importers import import_clip
    doc, report = import_clip("wave.glb", load_embodiment("nutty_desk"), mapping="map.json")

Each importer reads its file into source channels (`mapping.SourceChannel`); `mapping.resolve_channel`
picks the robot DoF of each (mapping file, exact name, then name ignoring case and separators); the
channel's values become keys of that DoF's track:

- rotations become the twist angle about the DoF's joint axis (swing-twist decomposition);
  translations are projected onto the axis; then `value * scale + offset`;
- glTF STEP -> constant keys, LINEAR -> linear keys, CUBICSPLINE -> bezier keys with free handles
  from the Hermite tangents (right = [dt/3, out*dt/3], left = [-dt_prev/3, -in*dt_prev/3]); a
  CUBICSPLINE *rotation* is sampled densely (>= 8 samples per segment, 60 Hz) into linear keys, since
  the angle of a spline-interpolated quaternion is not a cubic;
- BVH frames -> linear keys, dropping keys that linear interpolation reproduces within `tolerance`;
- CSV -> linear keys (or `interp`), option names for enum DoFs;
- values outside a DoF's limits are clamped (and counted in the report).

The clip is validated and compiled against the robot before it is returned.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from backend.importers.mapping import (ChannelMap, ClipImportError, MappingSpec, SourceChannel, load_mapping,
                                       parse_mapping, resolve_channel, swing_twist, twist_angle)

__all__ = ["ClipImportError", "FORMATS", "SourceChannel", "decimate", "detect_format", "format_report",
           "import_clip", "read_channels", "swing_twist", "twist_angle"]

FORMATS = {".gltf": "gltf", ".glb": "gltf", ".bvh": "bvh", ".csv": "csv"}


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


def read_channels(path: str | Path, fmt: str | None = None, animation: str | int | None = None
                  ) -> tuple[str, list[SourceChannel], dict[str, Any], list[str]]:
    """(format, channels, source info, notes) of a file."""
    path = Path(path)
    kind = detect_format(path, fmt)
    if not path.is_file():
        raise ClipImportError(f"no such file: '{path}'")
    if kind == "gltf":
        from backend.importers.gltf import read_gltf

        channels, info, notes = read_gltf(path, animation)
    elif kind == "bvh":
        from backend.importers.bvh import read_bvh

        channels, info, notes = read_bvh(path)
    else:
        from backend.importers.csv_clip import read_csv

        channels, info, notes = read_csv(path)
    if animation not in (None, "") and kind != "gltf":
        notes.append("--animation only applies to glTF files; ignored")
    return kind, channels, info, notes


def import_clip(path: str | Path, emb, mapping: str | Path | dict | MappingSpec | None = None, *,
                name: str | None = None, animation: str | int | None = None, tolerance: float = 1e-3,
                interp: str | None = None, fmt: str | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """Import an animation file for robot `emb`: (clip document, report). Raises ClipImportError.

    mapping: a mapping file path, a mapping dict (`{"joints": {...}}`) or None.
    animation: glTF animation name or index (default the first).
    tolerance: rad/m; BVH keys (and densely sampled spline rotations) that linear interpolation
      reproduces within it are dropped (0 keeps every frame).
    interp: for CSV, the keys' interpolation (constant, linear or bezier; default linear).
    """
    from backend.engine.clips import CLIP_FORMAT, Clip, ClipError, compile_clip

    if tolerance < 0 or not math.isfinite(tolerance):
        raise ClipImportError(f"tolerance must be a finite number >= 0, got {tolerance}")
    if interp is not None and interp not in ("constant", "linear", "bezier"):
        raise ClipImportError(f"interp must be constant, linear or bezier, got '{interp}'")
    spec: MappingSpec | None
    if mapping is None or isinstance(mapping, MappingSpec):
        spec = mapping
    elif isinstance(mapping, dict):
        spec = parse_mapping(mapping)
    else:
        spec = load_mapping(mapping)
    path = Path(path)
    kind, channels, info, notes = read_channels(path, fmt, animation)
    if not channels:
        raise ClipImportError(f"'{path}' has no animated channels")
    for ch in channels:
        t = np.asarray(ch.times, dtype=float)
        if len(t) == 0 or not np.all(np.isfinite(t)):
            raise ClipImportError(f"{ch.label}: no key times, or times that are not finite numbers")
        if np.any(np.diff(t) <= 0):
            raise ClipImportError(f"{ch.label}: key times must increase strictly")
    t0 = min(float(ch.times[0]) for ch in channels)
    shift = -t0 if t0 < 0 else 0.0
    if shift:
        notes.append(f"keys start at {t0:g} s; shifted by {shift:g} s so the clip starts at 0")
    end = max(float(ch.times[-1]) for ch in channels) + shift

    tracks: dict[str, list[dict[str, Any]]] = {}
    driven_by: dict[str, str] = {}
    mapped: list[dict[str, Any]] = []
    unmapped: list[dict[str, Any]] = []
    clamped: dict[str, int] = {}
    for ch in channels:
        cmap, reason = resolve_channel(ch, emb, spec)
        if cmap is not None and cmap.dof in driven_by:
            cmap, reason = None, f"DoF '{cmap.dof}' is already driven by '{driven_by[cmap.dof]}'"
        if cmap is None:
            unmapped.append({"source": ch.label, "kind": ch.kind, "reason": reason})
            continue
        try:
            keys, how_keys = _channel_keys(ch, cmap, emb, shift, tolerance, interp if kind == "csv" else None)
        except ClipImportError as exc:
            unmapped.append({"source": ch.label, "kind": ch.kind, "reason": str(exc)})
            continue
        n_clamped = _clamp(keys, emb.dof(cmap.dof))
        if n_clamped:
            clamped[cmap.dof] = n_clamped
        tracks[cmap.dof] = keys
        driven_by[cmap.dof] = ch.label
        entry: dict[str, Any] = {"source": ch.label, "kind": ch.kind, "dof": cmap.dof, "how": cmap.how,
                                 "interp": ch.interp, "keys": len(keys), "source_keys": len(ch.times),
                                 "conversion": how_keys}
        if cmap.axis is not None:
            entry["axis"] = [round(float(x), 6) for x in cmap.axis]
        if cmap.scale != 1.0 or cmap.offset != 0.0:
            entry["scale"], entry["offset"] = cmap.scale, cmap.offset
        if ch.detail:
            entry["detail"] = ch.detail
        mapped.append(entry)
    if not tracks:
        why = "; ".join(f"{u['source']}: {u['reason']}" for u in unmapped[:8])
        raise ClipImportError(f"no channel of '{path.name}' maps to a DoF of robot '{emb.name}' ({why})")

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
    try:
        Clip.model_validate(doc)  # the compact document is written as is (no defaults spelled out)
        compile_clip(doc, emb)
    except (ClipError, ValueError) as exc:
        raise ClipImportError(f"the imported clip does not fit robot '{emb.name}': {exc}") from exc
    report = {
        "file": str(path),
        "format": kind,
        "robot": emb.name,
        "clip": doc["name"],
        **{k: v for k, v in info.items()},
        "mapped": mapped,
        "unmapped": unmapped,
        "clamped": clamped,
        "clamped_total": sum(clamped.values()),
        "tracks": len(tracks),
        "keys": sum(len(k) for k in tracks.values()),
        "duration": float(doc.get("duration", 0.0)),
        "notes": notes,
    }
    return doc, report


# --------------------------------------------------------------------------------------------------
# Channel -> keys
# --------------------------------------------------------------------------------------------------


def _channel_keys(ch: SourceChannel, cmap: ChannelMap, emb, shift: float, tol: float,
                  interp: str | None) -> tuple[list[dict[str, Any]], str]:
    times = np.asarray(ch.times, dtype=float) + shift
    dof = emb.dof(cmap.dof)
    sc, off = cmap.scale, cmap.offset
    if ch.kind == "scalar" and not isinstance(ch.values, np.ndarray):
        # CSV column with option names (enum DoFs)
        if dof.type.value != "enum":
            raise ClipImportError(f"DoF '{cmap.dof}' is {dof.type.value} but the column has non-numeric "
                                  f"values ({next(v for v in ch.values if isinstance(v, str))!r})")
        return [{"t": float(t), "v": v if isinstance(v, str) else float(v), "interp": "constant"}
                for t, v in zip(times, ch.values)], "option names, constant keys"
    if ch.kind == "rotation":
        q = np.asarray(ch.values, dtype=float)
        if ch.interp == "CUBICSPLINE":
            ts, qs = _sample_hermite(times, q, np.asarray(ch.in_tangents), np.asarray(ch.out_tangents))
            vals = twist_angle(qs, cmap.axis) * sc + off
            t_keep, v_keep = decimate(ts, vals, tol / 4) if tol > 0 else (ts, vals)
            return _keys(t_keep, v_keep, "linear"), (
                f"spline rotation sampled at {len(ts)} points, twist angle, {len(t_keep)} linear keys")
        vals = twist_angle(q, cmap.axis) * sc + off
        how = "twist angle about the axis"
    elif ch.kind == "translation":
        vals = np.asarray(ch.values, dtype=float) @ cmap.axis * sc + off
        how = "projected onto the axis"
        if ch.interp == "CUBICSPLINE":
            a = np.asarray(ch.in_tangents, dtype=float) @ cmap.axis * sc
            b = np.asarray(ch.out_tangents, dtype=float) @ cmap.axis * sc
            return _bezier_keys(times, vals, a, b), how + ", bezier keys from the spline tangents"
    else:
        vals = np.asarray(ch.values, dtype=float) * sc + off
        how = "value"
        if ch.interp == "CUBICSPLINE":
            a = np.asarray(ch.in_tangents, dtype=float) * sc
            b = np.asarray(ch.out_tangents, dtype=float) * sc
            return _bezier_keys(times, vals, a, b), "bezier keys from the spline tangents"
    if ch.interp == "STEP":
        return _keys(times, vals, "constant"), how + ", constant keys"
    if interp is not None:
        return _keys(times, vals, interp), how + f", {interp} keys"
    if ch.decimate and tol > 0:
        t_keep, v_keep = decimate(times, vals, tol)
        return _keys(t_keep, v_keep, "linear"), how + f", linear keys ({len(times) - len(t_keep)} dropped within {tol:g})"
    return _keys(times, vals, "linear"), how + ", linear keys"


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
# Report
# --------------------------------------------------------------------------------------------------


def format_report(report: dict[str, Any]) -> str:
    """The import report for a person."""
    lines = [f"imported {report['file']} ({report['format']}"
             + (f", animation '{report['animation']}'" if report.get("animation") else "")
             + f") for robot '{report['robot']}': {report['tracks']} track(s), {report['keys']} key(s), "
             f"{report['duration']:g} s"]
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
            lines.append(f"  {m['source']} -> {m['dof']}  [{m['how']}; {m['interp']}; {m['conversion']}; "
                         f"{m['source_keys']} -> {m['keys']} keys{'; ' + '; '.join(extra) if extra else ''}]")
    if report["unmapped"]:
        lines.append("unmapped:")
        for u in report["unmapped"]:
            lines.append(f"  {u['source']}: {u['reason']}")
    if report["clamped_total"]:
        per = ", ".join(f"{d} {n}" for d, n in report["clamped"].items())
        lines.append(f"clamped {report['clamped_total']} key value(s) to the DoF limits ({per})")
    for note in report["notes"]:
        lines.append(f"note: {note}")
    return "\n".join(lines)
