"""One source channel -> the keys of the robot DoF(s) it drives.

Rotations: the change from the rest pose in the robot's axes, reduced to the twist about one DoF's
axis or split over two or three DoFs' axes (`rotations.davenport`); the dropped swing is measured.
Translations: the change from rest projected onto the DoF's axis. Scalars: scaled and offset;
option names (CSV) become constant keys of an enum DoF.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.importers.keys import bezier_keys, densify_slerp, is_sampled, make_keys, sample_hermite
from backend.importers.mapping import ChannelMap, ClipImportError, SourceChannel
from backend.importers.rotations import (
    RotationError,
    davenport,
    hemisphere,
    principal_axis,
    quat_angle,
    quat_conj,
    quat_mul,
    quat_normalise,
    quat_to_matrix,
    swing_twist,
    twist_angle,
)


def convert_channel(
    ch: SourceChannel,
    cmap: ChannelMap,
    emb: Embodiment,
    conv: np.ndarray,
    shift: float,
    tol: float,
    interp: str | None,
) -> dict[str, Any]:
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
            raise ClipImportError(
                f"DoF '{target.dof}' is {dof.type.value} but the column has non-numeric "
                f"values ({next(v for v in ch.values if isinstance(v, str))!r})"
            )
        keys = [
            {"t": float(t), "v": v if isinstance(v, str) else float(v), "interp": "constant"}
            for t, v in zip(times, ch.values)
        ]
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
            return {
                "tracks": [
                    (
                        bezier_keys(times, vals, a, b),
                        how + ", bezier keys from the spline tangents",
                        times,
                        vals,
                        0,
                    )
                ]
            }
    else:
        vals = np.asarray(ch.values, dtype=float) * sc + off
        how = "value"
        if ch.interp == "CUBICSPLINE":
            a = np.asarray(ch.in_tangents, dtype=float) * sc
            b = np.asarray(ch.out_tangents, dtype=float) * sc
            return {
                "tracks": [
                    (bezier_keys(times, vals, a, b), "bezier keys from the spline tangents", times, vals, 0)
                ]
            }
    if ch.interp == "STEP":
        mode = "constant"
    elif interp is not None:
        mode = interp
    elif (is_sampled(ch) and ch.kind != "scalar") or ch.decimate:
        mode = "smooth"
    else:
        mode = "linear"
    keys, how, n_cl = make_keys(times, vals, mode, tol, dof, how)
    return {"tracks": [(keys, how, times, vals, n_cl)]}


def _qrot(q: np.ndarray) -> np.ndarray:

    return quat_to_matrix(q)


def _convert_rotation(
    ch: SourceChannel, cmap: ChannelMap, emb: Embodiment, conv: np.ndarray, times: np.ndarray, tol: float
) -> dict[str, Any]:
    pre = quat_mul(conv, ch.pre)
    post = quat_mul(ch.post, quat_conj(conv))
    targets = cmap.targets
    axes = cmap.axes

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
    sampled = is_sampled(ch)
    force = None
    if ch.interp == "CUBICSPLINE":
        ts, qs = sample_hermite(times, q, np.asarray(ch.in_tangents), np.asarray(ch.out_tangents))
        qs = quat_normalise(qs)
        force = np.flatnonzero(np.isin(ts, times))  # the animator's own keys stay keys
        mode, first_ok = "smooth", False
        what = f"spline rotation sampled at {len(ts)} points"
    elif ch.interp == "STEP":
        ts, qs, what, mode, first_ok = times, q, "", "constant", True
    elif sampled:
        ts, qs, what, mode, first_ok = times, q, "", "smooth", True
    elif len(times) > 1:
        ts, qs, n_dense = densify_slerp(times, q, lambda d: angles(robot(d))[0], tol)
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
        how = (
            "angle " + " then ".join(f"{t.dof}" for t in targets) + " (decomposed in that order, robot frame)"
        )
    if what:
        how += f", {what}"
    out_tracks = []
    for j, target in enumerate(targets):
        vals = ang[:, j] * target.scale + target.offset
        keys, h, n_cl = make_keys(ts, vals, mode, tol, emb.dof(target.dof), how, force)
        out_tracks.append((keys, h, ts if first_ok else ts[:0], vals if first_ok else vals[:0], n_cl))
    axis, share = principal_axis(d)
    swing_deg = np.degrees(swing)
    sw = {
        "swing_max_deg": round(float(swing_deg.max(initial=0.0)), 4),
        "swing_rms_deg": round(float(np.sqrt(np.mean(swing_deg**2))) if len(swing_deg) else 0.0, 4),
        "principal_axis": [round(float(x), 4) + 0.0 for x in axis],
        "principal_share": round(share, 4),
    }
    return {"tracks": out_tracks, "swing": sw}
