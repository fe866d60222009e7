"""Animation curves as animators know them: keyframes with constant, linear, bezier or eased segments.

A curve is a list of keyframes `(t, v)`. The `interp` of a key shapes the segment *leaving* it (as in
Blender's Graph Editor): `constant` holds the value (steps), `linear` is a straight line, `bezier` is a
cubic Bezier through the key's right handle and the next key's left handle, and the easing presets
(`sine`, `quad`, `cubic`, `quart`, `quint`, `expo`, `circ`, `back`, `elastic`, `bounce`) ease from one
key to the next, `in`, `out` or `in_out`.

Handles are offsets `[dt, dv]` from their key (dt in s, dv in the DoF's unit). Their types:
- `auto`: smooth tangent through the neighbours (may overshoot between keys);
- `auto_clamped` (default): like auto, but flat at local extremes and at the ends, so the curve never
  overshoots a key — slow in/out for free;
- `vector`: points at the neighbouring key (a sharp corner, straight segment ends);
- `aligned`: the handle given on one side fixes the direction of the other (a smooth, authored tangent,
  e.g. an *anticipation* dip before a move);
- `free`: used exactly as given.
Handles are clamped in time to their segment so the curve stays a function of time.

Evaluation is vectorised: `CurveSet` packs many curves (one per DoF channel) into padded arrays and
evaluates all of them at one time with a few numpy operations (bracketed Newton on the Bezier's
x(u) = t), so a clip of 20 DoFs costs the same handful of array operations as one of 2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from backend.engine import compiled as _compiled
from backend.engine.compiled import curves as compiled_curves

default_compiled, entry_point = _compiled.default_compiled, _compiled.entry_point

Interp = Literal[
    "constant",
    "linear",
    "bezier",
    "sine",
    "quad",
    "cubic",
    "quart",
    "quint",
    "expo",
    "circ",
    "back",
    "elastic",
    "bounce",
]
EasingMode = Literal["in", "out", "in_out"]
HandleType = Literal["auto", "auto_clamped", "vector", "aligned", "free"]

INTERPS: tuple[str, ...] = (
    "constant",
    "linear",
    "bezier",
    "sine",
    "quad",
    "cubic",
    "quart",
    "quint",
    "expo",
    "circ",
    "back",
    "elastic",
    "bounce",
)
EASINGS: tuple[str, ...] = INTERPS[3:]
_CODE = {name: i for i, name in enumerate(INTERPS)}
_MODE = {"in": 0, "out": 1, "in_out": 2}


@dataclass
class Key:
    """One keyframe. `left`/`right` are handle offsets [dt, dv] (used by free/aligned handles)."""

    t: float
    v: float
    interp: str = "bezier"
    easing: str = "in_out"
    left_type: str = "auto_clamped"
    right_type: str = "auto_clamped"
    left: tuple[float, float] | None = None
    right: tuple[float, float] | None = None


# --------------------------------------------------------------------------------------------------
# Easing presets on u in [0, 1] (vectorised). Each `_in` form maps 0 -> 0 and 1 -> 1.
# --------------------------------------------------------------------------------------------------


def _bounce_out(u: np.ndarray) -> np.ndarray:
    n, d = 7.5625, 2.75
    u = np.asarray(u, dtype=float)
    return np.select(
        [u < 1 / d, u < 2 / d, u < 2.5 / d],
        [n * u * u, n * (u - 1.5 / d) ** 2 + 0.75, n * (u - 2.25 / d) ** 2 + 0.9375],
        n * (u - 2.625 / d) ** 2 + 0.984375,
    )


def _ease_in(name: str, u: np.ndarray) -> np.ndarray:
    if name == "sine":
        return 1.0 - np.cos(u * math.pi / 2)
    if name in ("quad", "cubic", "quart", "quint"):
        return u ** {"quad": 2, "cubic": 3, "quart": 4, "quint": 5}[name]
    if name == "expo":
        return np.where(u <= 0.0, 0.0, 2.0 ** (10.0 * np.minimum(u, 1.0) - 10.0) - (1 - u) * 2.0**-10)
    if name == "circ":
        return 1.0 - np.sqrt(np.maximum(0.0, 1.0 - u * u))
    if name == "back":
        c1 = 1.70158
        return (c1 + 1) * u**3 - c1 * u**2
    if name == "elastic":
        out = -(2.0 ** (10 * u - 10)) * np.sin((u * 10 - 10.75) * (2 * math.pi / 3))
        return np.where(u <= 0.0, 0.0, np.where(u >= 1.0, 1.0, out))
    if name == "bounce":
        return 1.0 - _bounce_out(1.0 - u)
    raise ValueError(f"unknown easing '{name}' (one of {list(EASINGS)})")


def ease(name: str, mode: str, u: np.ndarray | float) -> np.ndarray:
    """Eased fraction for `u` in [0, 1]: `in` starts slowly, `out` ends slowly, `in_out` both.

    back and elastic overshoot on purpose (anticipation, follow-through)."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    if mode == "in":
        return _ease_in(name, u)
    if mode == "out":
        return 1.0 - _ease_in(name, 1.0 - u)
    if mode == "in_out":
        return np.where(u < 0.5, 0.5 * _ease_in(name, 2 * u), 1.0 - 0.5 * _ease_in(name, 2 - 2 * u))
    raise ValueError(f"unknown easing mode '{mode}' (one of {list(_MODE)})")


# --------------------------------------------------------------------------------------------------
# Handles
# --------------------------------------------------------------------------------------------------


def _auto_slope(keys: Sequence[Key], i: int, clamped: bool) -> float:
    k = keys[i]
    if len(keys) == 1:
        return 0.0
    if i == 0 or i == len(keys) - 1:
        if clamped:
            return 0.0
        other = keys[1] if i == 0 else keys[-2]
        return (other.v - k.v) / (other.t - k.t)
    prev, nxt = keys[i - 1], keys[i + 1]
    slope = (nxt.v - prev.v) / (nxt.t - prev.t)
    if clamped:
        if (k.v - prev.v) * (nxt.v - k.v) <= 0.0:  # a local extreme (or a plateau): flat, no overshoot
            return 0.0
        # Limit the slope so neither neighbouring segment overshoots (monotone cubic, Fritsch-Carlson).
        s0 = (k.v - prev.v) / (k.t - prev.t)
        s1 = (nxt.v - k.v) / (nxt.t - k.t)
        limit = 3.0 * min(abs(s0), abs(s1))
        slope = math.copysign(min(abs(slope), limit), slope)
    return slope


def resolve_handles(keys: Sequence[Key]) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Absolute (left, right) handle points [t, v] for every key, after applying the handle types.

    Handles reach at most a third of the way... unless free/aligned; every handle's time is clamped to
    its segment so the curve stays a function of time."""
    out = []
    n = len(keys)
    for i, k in enumerate(keys):
        span_l = k.t - keys[i - 1].t if i > 0 else 0.0
        span_r = keys[i + 1].t - k.t if i < n - 1 else 0.0
        left = _handle(keys, i, "left", span_l)
        right = _handle(keys, i, "right", span_r)
        # aligned: a given handle on one side sets the direction of the other side
        if k.left_type == "aligned" and k.right is not None and k.right_type in ("free", "aligned"):
            left = _align(right, span_l, k.left)
        elif k.right_type == "aligned" and k.left is not None and k.left_type in ("free", "aligned"):
            right = _align(left, span_r, k.right)
        dt_l = min(max(left[0], -span_l), 0.0)
        dt_r = max(min(right[0], span_r), 0.0)
        # keep the slope of a clamped handle (shorten it in time and value together)
        vl = left[1] * (dt_l / left[0]) if left[0] != 0.0 else 0.0
        vr = right[1] * (dt_r / right[0]) if right[0] != 0.0 else 0.0
        out.append(((k.t + dt_l, k.v + vl), (k.t + dt_r, k.v + vr)))
    return out


def _handle(keys: Sequence[Key], i: int, side: str, span: float) -> tuple[float, float]:
    k = keys[i]
    kind = k.left_type if side == "left" else k.right_type
    given = k.left if side == "left" else k.right
    sign = -1.0 if side == "left" else 1.0
    if kind in ("free", "aligned") and given is not None:
        return float(given[0]), float(given[1])
    if kind == "vector":
        j = i - 1 if side == "left" else i + 1
        if 0 <= j < len(keys):
            return (keys[j].t - k.t) / 3.0, (keys[j].v - k.v) / 3.0
        return 0.0, 0.0
    slope = _auto_slope(keys, i, clamped=(kind != "auto"))
    dt = sign * span / 3.0
    return dt, slope * dt


def _align(other: tuple[float, float], span: float, given: tuple[float, float] | None) -> tuple[float, float]:
    """A handle opposite to `other`, of its given length (or a third of its segment)."""
    odt, odv = other
    norm = math.hypot(odt, odv)
    if norm == 0.0:
        return (0.0, 0.0)
    length = math.hypot(*given) if given is not None else span / 3.0
    if given is not None and length == 0.0:
        length = span / 3.0
    return (-odt / norm * length, -odv / norm * length)


# --------------------------------------------------------------------------------------------------
# Vectorised evaluation of many curves
# --------------------------------------------------------------------------------------------------


class CurveSet:
    """Many curves packed for vectorised evaluation: `evaluate(t)` gives one value per curve.

    Before its first key a curve holds the first value, after its last key the last value."""

    def __init__(self, curves: Sequence[Sequence[Key]]):
        if not curves:
            raise ValueError("a curve set needs at least one curve")
        for c in curves:
            if not c:
                raise ValueError("every curve needs at least one key")
            times = [k.t for k in c]
            if any(b <= a for a, b in zip(times, times[1:])):
                raise ValueError(f"key times must increase strictly, got {times}")
        n = len(curves)
        m = max(len(c) for c in curves)
        self.n_keys = np.array([len(c) for c in curves])
        self.t = np.full((n, m), np.inf)
        self.v = np.zeros((n, m))
        self.h_right = np.zeros((n, m, 2))  # absolute handle points
        self.h_left = np.zeros((n, m, 2))
        self.code = np.zeros((n, m), dtype=np.int64)
        self.mode = np.zeros((n, m), dtype=np.int64)
        for i, c in enumerate(curves):
            handles = resolve_handles(c)
            for j, k in enumerate(c):
                if k.interp not in _CODE:
                    raise ValueError(f"unknown interpolation '{k.interp}' (one of {list(INTERPS)})")
                if k.easing not in _MODE:
                    raise ValueError(f"unknown easing mode '{k.easing}' (one of {list(_MODE)})")
                self.t[i, j], self.v[i, j] = k.t, k.v
                self.h_left[i, j], self.h_right[i, j] = handles[j][0], handles[j][1]
                self.code[i, j], self.mode[i, j] = _CODE[k.interp], _MODE[k.easing]
            # pad: repeat the last key so gathers past the end stay finite
            self.v[i, len(c) :] = c[-1].v
        self.rows = np.arange(n)
        self.start = float(np.min(self.t[:, 0]))
        self.end = float(np.max(self.t[self.rows, self.n_keys - 1]))
        self._present = sorted(set(self.code[self.t < np.inf].tolist()))
        self._kernel = None  # the compiled evaluation, fetched on first use

    def evaluate(self, t: float) -> np.ndarray:
        """Values of every curve at time `t` (s) (compiled, unless NUTTY_REFERENCE=1 selects the numpy
        reference, `evaluate_reference`)."""
        if default_compiled():
            if self._kernel is None:
                self._kernel = entry_point(compiled_curves.evaluate, compiled_curves.EVALUATE_SIG)
            out = np.empty(len(self.rows))
            self._kernel(
                self.t, self.v, self.h_right, self.h_left, self.code, self.mode, self.n_keys, float(t), out
            )
            return out
        return self.evaluate_reference(t)

    def evaluate_reference(self, t: float) -> np.ndarray:
        """The numpy definition of `evaluate`."""
        rows = self.rows
        last = self.n_keys - 1
        idx = np.minimum(np.sum(self.t <= t, axis=1) - 1, last)  # key at or before t
        before = idx < 0
        idx = np.maximum(idx, 0)
        at_end = idx >= last
        nxt = np.minimum(idx + 1, last)
        t0, t1 = self.t[rows, idx], self.t[rows, nxt]
        v0, v1 = self.v[rows, idx], self.v[rows, nxt]
        span = np.where(at_end, 1.0, t1 - t0)
        u = np.clip((t - t0) / span, 0.0, 1.0)
        code = self.code[rows, idx]
        out = v0.copy()
        for c in self._present:
            sel = (code == c) & ~at_end & ~before
            if not sel.any():
                continue
            name = INTERPS[c]
            if name == "constant":
                continue
            if name == "linear":
                out[sel] = v0[sel] + u[sel] * (v1[sel] - v0[sel])
            elif name == "bezier":
                out[sel] = self._bezier(sel, rows[sel], idx[sel], nxt[sel], t)
            else:
                modes = self.mode[rows, idx]
                for m_name, m in _MODE.items():
                    s = sel & (modes == m)
                    if s.any():
                        out[s] = v0[s] + ease(name, m_name, u[s]) * (v1[s] - v0[s])
        out[before] = self.v[rows[before], 0]
        out[at_end & ~before] = self.v[rows[at_end & ~before], last[at_end & ~before]]
        return out

    def _bezier(self, sel, rows, i0, i1, t: float) -> np.ndarray:
        x0, y0 = self.t[rows, i0], self.v[rows, i0]
        x3, y3 = self.t[rows, i1], self.v[rows, i1]
        x1, y1 = self.h_right[rows, i0, 0], self.h_right[rows, i0, 1]
        x2, y2 = self.h_left[rows, i1, 0], self.h_left[rows, i1, 1]
        # Solve x(u) = t on [0, 1]: x is monotone since the handles lie within the segment in time.
        lo, hi = np.zeros_like(x0), np.ones_like(x0)
        u = (t - x0) / (x3 - x0)
        for _ in range(12):
            a = 1.0 - u
            x = a * a * a * x0 + 3 * a * a * u * x1 + 3 * a * u * u * x2 + u * u * u * x3
            f = x - t
            lo = np.where(f < 0, u, lo)
            hi = np.where(f > 0, u, hi)
            dx = 3 * a * a * (x1 - x0) + 6 * a * u * (x2 - x1) + 3 * u * u * (x3 - x2)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = u - f / dx
            ok = np.isfinite(step) & (step >= lo) & (step <= hi)
            u = np.where(ok, step, 0.5 * (lo + hi))
        a = 1.0 - u
        return a * a * a * y0 + 3 * a * a * u * y1 + 3 * a * u * u * y2 + u * u * u * y3
