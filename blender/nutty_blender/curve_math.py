"""The engine's curve rules in plain Python (no bpy), for Import clip: where a clip's Bezier handles are
(`resolve_handles`, the handle types auto, auto_clamped, vector, aligned and free as
docs/program-format.md defines them) and the easings Blender computes differently (`ease`: expo,
elastic, back in-out), so an imported clip shows in Blender the very curve the engine plays.

Times in s, values in the DoF's unit; a handle is an offset (dt, dv) from its key or, resolved, an
absolute point (t, v). Every resolved handle lies within its segment in time (a longer one is shortened
keeping its slope), so each segment stays a function of time.
"""

from __future__ import annotations

import math
from typing import Any

BACK = 1.70158  # the engine's (and Blender's default) overshoot of `back`


def _ease_in(name: str, u: float) -> float:
    """The `in` form of an easing on u in [0, 1]: 0 -> 0, 1 -> 1."""
    if name == "expo":
        return 0.0 if u <= 0.0 else 2.0 ** (10.0 * min(u, 1.0) - 10.0) - (1.0 - u) * 2.0**-10
    if name == "elastic":
        if u <= 0.0 or u >= 1.0:
            return 0.0 if u <= 0.0 else 1.0
        return -(2.0 ** (10.0 * u - 10.0)) * math.sin((10.0 * u - 10.75) * (2.0 * math.pi / 3.0))
    if name == "back":
        return (BACK + 1.0) * u**3 - BACK * u**2
    if name == "sine":
        return 1.0 - math.cos(u * math.pi / 2.0)
    if name in ("quad", "cubic", "quart", "quint"):
        return u ** {"quad": 2, "cubic": 3, "quart": 4, "quint": 5}[name]
    if name == "circ":
        return 1.0 - math.sqrt(max(0.0, 1.0 - u * u))
    if name == "bounce":
        return 1.0 - _bounce_out(1.0 - u)
    raise ValueError(f"unknown easing '{name}'")


def _bounce_out(u: float) -> float:
    n, d = 7.5625, 2.75
    if u < 1 / d:
        return n * u * u
    if u < 2 / d:
        return n * (u - 1.5 / d) ** 2 + 0.75
    if u < 2.5 / d:
        return n * (u - 2.25 / d) ** 2 + 0.9375
    return n * (u - 2.625 / d) ** 2 + 0.984375


def ease(name: str, mode: str, u: float) -> float:
    """The eased fraction at u (clamped to [0, 1]) for mode `in`, `out` or `in_out`, as the engine."""
    u = min(max(u, 0.0), 1.0)
    if mode == "in":
        return _ease_in(name, u)
    if mode == "out":
        return 1.0 - _ease_in(name, 1.0 - u)
    return 0.5 * _ease_in(name, 2.0 * u) if u < 0.5 else 1.0 - 0.5 * _ease_in(name, 2.0 - 2.0 * u)


def _auto_slope(keys: list[dict[str, Any]], i: int, clamped: bool) -> float:
    """An automatic handle's slope (value per s) at key i: the neighbours' chord; clamped: flat at an
    extreme or an end, and no steeper than 3x either side's chord (the segments never overshoot)."""
    n = len(keys)
    if n == 1:
        return 0.0
    t, v = keys[i]["t"], keys[i]["v"]
    if i in (0, n - 1):
        if clamped:
            return 0.0
        other = keys[1] if i == 0 else keys[-2]
        return (other["v"] - v) / (other["t"] - t)
    (tp, vp), (tn, vn) = (keys[i - 1]["t"], keys[i - 1]["v"]), (keys[i + 1]["t"], keys[i + 1]["v"])
    slope = (vn - vp) / (tn - tp)
    if not clamped:
        return slope
    if (v - vp) * (vn - v) <= 0.0:
        return 0.0
    limit = 3.0 * min(abs((v - vp) / (t - tp)), abs((vn - v) / (tn - t)))
    return math.copysign(min(abs(slope), limit), slope)


def _offset(keys: list[dict[str, Any]], i: int, side: str, span: float) -> tuple[float, float]:
    """Key i's handle on `side` as an offset, by its type (before the aligned rule and the clamp)."""
    k = keys[i]
    kind = k.get(f"{side}_type", "auto_clamped")
    given = k.get(side)
    if kind in ("free", "aligned") and given is not None:
        return float(given[0]), float(given[1])
    if kind == "vector":
        j = i - 1 if side == "left" else i + 1
        if 0 <= j < len(keys):
            return (keys[j]["t"] - k["t"]) / 3.0, (keys[j]["v"] - k["v"]) / 3.0
        return 0.0, 0.0
    dt = (-1.0 if side == "left" else 1.0) * span / 3.0
    return dt, _auto_slope(keys, i, clamped=kind != "auto") * dt


def _opposite(other: tuple[float, float], span: float, given: Any) -> tuple[float, float]:
    """An aligned handle: opposite `other`, as long as given (or a third of its segment)."""
    norm = math.hypot(*other)
    if norm == 0.0:
        return 0.0, 0.0
    length = math.hypot(*given) if given is not None else 0.0
    length = length or span / 3.0
    return -other[0] / norm * length, -other[1] / norm * length


def resolve_handles(keys: list[dict[str, Any]]) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Absolute (left, right) handle points (t, v) of each numeric key (dicts with t, v and the clip's
    handle fields), as the engine resolves them."""
    out = []
    n = len(keys)
    for i, k in enumerate(keys):
        span_l = k["t"] - keys[i - 1]["t"] if i > 0 else 0.0
        span_r = keys[i + 1]["t"] - k["t"] if i < n - 1 else 0.0
        left, right = _offset(keys, i, "left", span_l), _offset(keys, i, "right", span_r)
        lt, rt = k.get("left_type", "auto_clamped"), k.get("right_type", "auto_clamped")
        if lt == "aligned" and k.get("right") is not None and rt in ("free", "aligned"):
            left = _opposite(right, span_l, k.get("left"))
        elif rt == "aligned" and k.get("left") is not None and lt in ("free", "aligned"):
            right = _opposite(left, span_r, k.get("right"))
        dt_l, dt_r = min(max(left[0], -span_l), 0.0), max(min(right[0], span_r), 0.0)
        dv_l = left[1] * dt_l / left[0] if left[0] != 0.0 else 0.0
        dv_r = right[1] * dt_r / right[0] if right[0] != 0.0 else 0.0
        out.append(((k["t"] + dt_l, k["v"] + dv_l), (k["t"] + dt_r, k["v"] + dv_r)))
    return out
