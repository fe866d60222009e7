"""Source channels -> robot DoF tracks: each channel resolved to its DoF(s) (mapping-file entries
first, then names), converted to keys and clamped to the DoF's limits, with a report row per DoF
driven and a reason for every channel left out (a DoF is driven by one channel only).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.importers.clip_warnings import swing_warning
from backend.importers.convert import convert_channel
from backend.importers.keys import clamp_keys, is_sampled
from backend.importers.mapping import ChannelMap, ClipImportError, MappingSpec, SourceChannel, resolve_channel


@dataclass(frozen=True)
class TrackOptions:
    """How channels become keys. conv: the source-to-robot axis quaternion (w, x, y, z); conversion:
    {"up", "forward"} for the report (None for CSV); shift: s added to every key time; tolerance:
    rad/m; interp: the CSV --interp (None otherwise); swing_warn: degrees."""

    conv: np.ndarray
    conversion: dict[str, str] | None
    shift: float
    tolerance: float
    interp: str | None
    swing_warn: float


@dataclass
class MappedChannels:
    """What the channels became: keys per DoF, the report's mapped/unmapped rows, clamped key counts
    per DoF, the first two frames of sampled channels (for the first-frame check) and warnings."""

    tracks: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    mapped: list[dict[str, Any]] = field(default_factory=list)
    unmapped: list[dict[str, Any]] = field(default_factory=list)
    clamped: dict[str, int] = field(default_factory=dict)
    first_frames: list[tuple[str, float, float, float, SourceChannel]] = field(default_factory=list)
    warnings: list[dict[str, Any]] = field(default_factory=list)


def map_channels(
    channels: list[SourceChannel], emb: Embodiment, spec: MappingSpec | None, opts: TrackOptions
) -> MappedChannels:
    """Resolve, convert and clamp every channel; report rows keep the channels' order."""
    resolved = [(ch, *resolve_channel(ch, emb, spec)) for ch in channels]

    def named_first(i: int) -> tuple[bool, int]:
        """Channels named by the mapping file claim their DoFs before channels matched by name."""
        cmap = resolved[i][1]
        return (cmap is None or cmap.key is None, i)

    order = sorted(range(len(resolved)), key=named_first)
    out = MappedChannels()
    driven_by: dict[str, str] = {}
    rows: dict[int, list[dict[str, Any]]] = {}
    for i in order:
        ch, cmap, reason = resolved[i]
        if cmap is not None:
            taken = [t.dof for t in cmap.targets if t.dof in driven_by]
            if taken:
                cmap, reason = None, f"DoF '{taken[0]}' is already driven by '{driven_by[taken[0]]}'"
        if cmap is None:
            rows[i] = [{"source": ch.label, "kind": ch.kind, "reason": reason, "_unmapped": True}]
            continue
        try:
            converted = convert_channel(ch, cmap, emb, opts.conv, opts.shift, opts.tolerance, opts.interp)
        except ClipImportError as exc:
            rows[i] = [{"source": ch.label, "kind": ch.kind, "reason": str(exc), "_unmapped": True}]
            continue
        rows[i] = _add_tracks(ch, cmap, converted, emb, out, driven_by)
        sw = converted.get("swing")
        if sw and sw["swing_max_deg"] > opts.swing_warn:
            out.warnings.append(swing_warning(ch, cmap, sw, emb, opts.swing_warn, opts.conversion))
    for i in range(len(resolved)):
        for row in rows.get(i, []):
            (out.unmapped if row.pop("_unmapped", False) else out.mapped).append(row)
    return out


def _add_tracks(
    ch: SourceChannel,
    cmap: ChannelMap,
    converted: dict[str, Any],
    emb: Embodiment,
    out: MappedChannels,
    driven_by: dict[str, str],
) -> list[dict[str, Any]]:
    """Store the converted keys of each target DoF (clamped) in `out`; the report rows."""
    rows = []
    for target, (keys, how_keys, raw_t, raw_v, n_pre) in zip(cmap.targets, converted["tracks"]):
        n_clamped = n_pre + clamp_keys(keys, emb.dof(target.dof))
        if n_clamped:
            out.clamped[target.dof] = n_clamped
        out.tracks[target.dof] = keys
        driven_by[target.dof] = ch.label
        rows.append(_mapped_row(ch, cmap, target, keys, how_keys, converted.get("swing")))
        if len(raw_t) >= 3 and is_sampled(ch):  # frames of a motion, not an animator's keys
            out.first_frames.append(
                (
                    target.dof,
                    float(raw_t[1] - raw_t[0]),
                    float(raw_v[1] - raw_v[0]),
                    float(np.max(np.abs(np.diff(raw_v[1:]))) if len(raw_v) > 2 else 0.0),
                    ch,
                )
            )
    return rows


def _mapped_row(
    ch: SourceChannel,
    cmap: ChannelMap,
    target,
    keys: list[dict[str, Any]],
    how_keys: str,
    swing: dict[str, Any] | None,
) -> dict[str, Any]:
    row: dict[str, Any] = {
        "source": ch.label,
        "kind": ch.kind,
        "dof": target.dof,
        "how": cmap.how,
        "interp": ch.interp,
        "keys": len(keys),
        "source_keys": len(ch.times),
        "conversion": how_keys,
    }
    if target.axis is not None:
        row["axis"] = [round(float(x), 6) for x in target.axis]
    if target.scale != 1.0 or target.offset != 0.0:
        row["scale"], row["offset"] = target.scale, target.offset
    if ch.detail:
        row["detail"] = ch.detail
    if ch.rest_note and ch.kind in ("rotation", "translation"):
        row["rest"] = ch.rest_note
    if swing:
        row.update(swing)
    return row
