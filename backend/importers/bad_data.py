"""Bad data in source channels: key times that do not increase, non-finite values or zero-length
quaternions (an error naming the channel and the sample, or repaired with `fill`), and dropping a
file's first frames (--skip-frames).
"""

from __future__ import annotations

import numpy as np

from backend.importers.mapping import ClipImportError, SourceChannel
from backend.importers.rotations import slerp


def check_times(ch: SourceChannel, where: str) -> None:
    """Key times (s) must be finite and increase strictly: an error naming the first bad sample."""
    t = np.asarray(ch.times, dtype=float)
    if len(t) == 0 or not np.all(np.isfinite(t)):
        raise ClipImportError(f"{where}: {ch.label}: no key times, or times that are not finite numbers")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise ClipImportError(
            f"{where}: {ch.label}: {ch.unit} {k} (t = {t[k]:g} s): key times must increase "
            f"strictly ({t[k - 1]:g} then {t[k]:g})"
        )


def check_values(ch: SourceChannel, where: str, fill: str | None, max_gap: int) -> int:
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
        hint = (
            ""
            if fill is not None
            else f"\n  --fill hold or --fill linear repairs gaps of up to {max_gap} {ch.unit}s"
        )
        raise ClipImportError(
            f"{where}: {ch.unit} {k} (t = {t[k]:g} s): {ch.label}: {part} "
            f"{what if not tan_bad[k] or bad[k] else 'is not finite'}{more}{hint}"
        )
    good = np.flatnonzero(~bad)
    if good.size == 0:
        raise ClipImportError(f"{where}: {ch.label}: no {ch.unit} has a usable value; nothing to fill from")
    d = np.diff(np.concatenate([[0], bad.astype(np.int8), [0]]))
    runs = list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))
    for a, b in runs:
        if b - a > max_gap:
            raise ClipImportError(
                f"{where}: {ch.unit}s {a}-{b - 1} (t = {t[a]:g}-{t[b - 1]:g} s): {ch.label}: "
                f"a gap of {b - a} unusable {ch.unit}s, longer than --max-gap {max_gap}"
            )
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


def drop_first_frames(
    channels: list[SourceChannel], n: int, notes: list[str], where: str
) -> list[SourceChannel]:
    """Drop the first `n` frames (distinct key times over all channels)."""
    times = np.unique(np.concatenate([np.asarray(ch.times, dtype=float) for ch in channels]))
    if n >= len(times):
        raise ClipImportError(
            f"{where}: --skip-frames {n}: the file has only {len(times)} distinct key time(s)"
        )
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
        if ch.out_tangents is not None:
            ch.out_tangents = ch.out_tangents[keep]
    notes.append(f"--skip-frames {n}: dropped the keys before t = {cut:g} s; the clip starts there")
    return channels
