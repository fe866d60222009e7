"""Warnings about an imported clip, with the option that would help: rotation dropped by reducing a
channel to its DoF axes (the *swing*), and a first frame that jumps like a T-pose or rest frame.
"""

from __future__ import annotations

import math
import shlex
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.importers.mapping import ChannelMap, SourceChannel, dof_axis
from backend.importers.rotations import (
    RotationError,
    axis_conversion,
    quat_angle,
    quat_conj,
    quat_mul,
    quat_to_matrix,
)


def option_text(option: str, value: str) -> str:
    """An option as a hint writes it, so that it parses when typed into a shell: `--forward z`, or
    `--forward=-z` for a value starting with '-' (which argparse would read as an option of its own);
    the value quoted where a shell needs it (`--animation 'walk cycle'`)."""
    text = shlex.quote(value)
    return f"{option}={text}" if value.startswith("-") else f"{option} {text}"


def _fmt_axis(a: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.3g}" if abs(x) > 5e-4 else "0" for x in a) + "]"


def _other_conversions(axis: np.ndarray, target: np.ndarray, conversion: dict[str, str] | None) -> list[str]:
    """Options (`--forward z`, `--up z`, ...) under which the principal axis `axis` (robot frame under
    the current conversion) would lie along the DoF's axis `target`: the same --up first."""
    if not conversion:
        return []

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
                parts = ([f"--up {u}"] if u != up else []) + (
                    [option_text("--forward", f)] if f != "x" or u == up else []
                )
                out.append(" ".join(parts))
        if out:
            break
    return out[:2]


def swing_warning(
    ch: SourceChannel,
    cmap: ChannelMap,
    sw: dict[str, Any],
    emb: Embodiment,
    limit: float,
    conversion: dict[str, str] | None = None,
) -> dict[str, Any]:
    axis = np.array(sw["principal_axis"])
    dofs = [t.dof for t in cmap.targets]
    forwards = _other_conversions(axis, cmap.axes[0], conversion) if len(dofs) == 1 else []
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
    msg = (
        f"{ch.label} -> {target}: drops up to {sw['swing_max_deg']:.1f} deg (RMS {sw['swing_rms_deg']:.1f} deg) "
        f"of rotation about other axes; the channel turns mostly about {_fmt_axis(axis)} in the robot's frame "
        f"({100 * sw['principal_share']:.0f}% of its motion)"
    )
    if forwards:
        hint = (
            f"if the source faces or stands another way, {' or '.join(forwards)} turns that axis onto "
            f"{dofs[0]}'s; "
        )
    else:
        hint = ""
    hint += f'to keep the motion as it is, "axis": {_fmt_axis(axis)} in the mapping file'
    if best is not None and best_dot > 0.9 and best not in dofs:
        hint += f", or map it to '{best}' (whose axis is closest)"
    return {
        "code": "swing",
        "channel": ch.label,
        "dofs": dofs,
        "message": msg,
        "hint": hint,
        "swing_max_deg": sw["swing_max_deg"],
        "swing_rms_deg": sw["swing_rms_deg"],
        "suggested_axis": [round(float(x), 4) + 0.0 for x in axis],
        "threshold_deg": limit,
    }


def first_frame_warning(
    rows: list[tuple[str, float, float, float, SourceChannel]],
    emb: Embodiment,
    skipped: int,
    conv: np.ndarray,
) -> dict[str, Any] | None:
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
    n_dofs = sum(
        1
        for dof_, dt, j, later, _c in rows
        if dt > 0 and abs(j) > emb.dof(dof_).velocity * dt and abs(j) > 3 * later
    )
    rest_like = all(
        float(quat_angle(quat_mul(quat_mul(c.pre, np.asarray(c.values[0], dtype=float)), c.post)))
        < math.radians(1.0)
        for _d, _t, _j, _l, c in rows
        if c.kind == "rotation"
    )
    kind = "the rest pose (a T-pose)" if rest_like else "a T-pose or rest frame"
    frame = skipped
    msg = (
        f"the first {ch.unit} ({ch.unit} {frame}) jumps {math.degrees(abs(jump)):.1f} deg to the next on '{dof}' "
        f"(it can move {math.degrees(can):.2f} deg in one {ch.unit}; {n_dofs} DoF(s) jump like this): it looks "
        f"like {kind}"
    )
    return {
        "code": "first_frame",
        "channel": ch.label,
        "dofs": [dof],
        "message": msg,
        "hint": f"--skip-frames {skipped + 1} drops it",
    }
