"""The import report: built from the pipeline's results, and formatted for a person."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from backend.engine.embodiment import Embodiment
from backend.importers.tracks import MappedChannels


def build_report(
    path: Path,
    kind: str,
    emb: Embodiment,
    doc: dict[str, Any],
    info: dict[str, Any],
    conversion: dict[str, str] | None,
    result: MappedChannels,
    filled: dict[str, int],
    notes: list[str],
) -> dict[str, Any]:
    """The report of an import (`notes` is kept, not copied: later steps add to it)."""
    tracks = result.tracks
    return {
        "file": str(path),
        "format": kind,
        "robot": emb.name,
        "clip": doc["name"],
        **info,
        "conversion": conversion,
        "mapped": result.mapped,
        "unmapped": result.unmapped,
        "clamped": result.clamped,
        "clamped_total": sum(result.clamped.values()),
        "tracks": len(tracks),
        "keys": sum(len(k) for k in tracks.values()),
        "duration": float(doc.get("duration", 0.0)),
        "filled": {"samples": sum(filled.values()), "channels": filled} if filled else None,
        "warnings": result.warnings,
        "notes": notes,
    }


def format_report(report: dict[str, Any]) -> str:
    """The import report for a person."""
    lines = [
        f"imported {report['file']} ({report['format']}"
        + (f", animation '{report['animation']}'" if report.get("animation") else "")
        + f") for robot '{report['robot']}': {report['tracks']} track(s), {report['keys']} key(s), "
        f"{report['duration']:g} s"
    ]
    conv = report.get("conversion")
    if conv:
        lines.append(
            f"axes: source +{conv['up'].lstrip('+')} up and {conv['forward']} forward "
            "-> robot +Z up, +X forward"
        )
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
                extra.append(
                    f"swing dropped max {m['swing_max_deg']:.2f} deg, RMS {m['swing_rms_deg']:.2f} deg"
                )
            lines.append(
                f"  {m['source']} -> {m['dof']}  [{m['how']}; {m['interp']}; {m['conversion']}; "
                f"{m['source_keys']} -> {m['keys']} keys{'; ' + '; '.join(extra) if extra else ''}]"
            )
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
        lines.append(
            "limits: every DoF is within its velocity, acceleration and jerk limits "
            f"(sampled at {lim['rate']:g} Hz)"
        )
        return lines
    n = next(iter(rows.values()))["samples"]
    lines.append(f"limits (trajectory-helper, {n} samples at {lim['rate']:g} Hz; samples over each limit):")
    for d, c in over.items():
        lines.append(
            f"  {d}: velocity {c['velocity']} (peak {c['max_velocity']:.3g} / {c['velocity_limit']:g}), "
            f"acceleration {c['acceleration']} "
            f"(peak {c['max_acceleration']:.3g} / {c['acceleration_limit']:g}), "
            f"jerk {c['jerk']} (peak {c['max_jerk']:.3g} / {c['jerk_limit']:g})"
        )
    s = lim.get("fit_scale")
    if s is not None and s > 1:
        lines.append(f"  to fit: play it {s:.3g}x slower (--fit-limits applies that)")
    elif s is None and lim.get("nmf"):
        lines.append(f"  to fit: no slow-down up to {lim.get('max_scale', 20):g}x fits")
    nmf = lim.get("nmf")
    if nmf:
        lines.append(
            f"  or filter it: NMF preset {nmf['best']} ({nmf['meaning']}) keeps its shape best "
            f"(RMS {nmf['rms_deg']:.2f} deg, max {nmf['max_deg']:.2f} deg from the clip)"
        )
    return lines
