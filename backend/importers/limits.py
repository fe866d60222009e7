"""The trajectory-helper on an imported clip: where it breaks the robot's limits and what it would need.

`analyse_clip(doc, emb, rate)` samples every continuous track of the clip at the engine's tick rate
(the importer's keys: constant, linear, and bezier keys whose handles sit at a third of their
segments, so the curve is evaluated exactly and vectorised), counts per DoF the samples over the
velocity, acceleration and jerk limits (`backend.engine.trajectory.limit_counts`, the same finite
differences as the editor's colouring), and when any is over, says what would fit:

- `fit_scale`: the uniform slow-down factor that brings every DoF within its limits
  (`trajectory.time_scale_to_fit`); `scale_clip_time` applies it (`--fit-limits`);
- `nmf`: the Nutty Motion Filter preset whose ghost keeps the clip's shape best under the limits
  (`trajectory.preset_fit`), with its RMS and largest deviation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from backend.engine import trajectory
from backend.engine.embodiment import Embodiment

MAX_SCALE = 20.0
SEARCH_BUDGET = 4e6  # samples x DoFs one fit evaluation may take (a long clip searches a shorter range)


class _Track:
    def __init__(self, keys: list[dict[str, Any]]):
        self.t = np.array([k["t"] for k in keys], dtype=float)
        self.v = np.array([k["v"] for k in keys], dtype=float)
        self.code = np.array(
            [{"constant": 0, "linear": 1, "bezier": 2}.get(k.get("interp", "linear"), 1) for k in keys]
        )
        self.ry = np.array([(k.get("right") or [0.0, 0.0])[1] for k in keys], dtype=float)
        self.ly = np.array([(k.get("left") or [0.0, 0.0])[1] for k in keys], dtype=float)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        n = len(self.t)
        if n == 1:
            return np.full(t.shape, self.v[0])
        i = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, n - 2)
        t0, t1 = self.t[i], self.t[i + 1]
        u = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        v0, v1 = self.v[i], self.v[i + 1]
        code = self.code[i]
        out = np.where(code == 0, v0, v0 + u * (v1 - v0))
        bz = code == 2
        if bz.any():
            p1 = v0 + self.ry[i]
            p2 = v1 + self.ly[i + 1]
            w = 1.0 - u
            cub = w**3 * v0 + 3 * w * w * u * p1 + 3 * w * u * u * p2 + u**3 * v1
            out = np.where(bz, cub, out)
        out = np.where(t < self.t[0], self.v[0], out)
        return np.where(t >= self.t[-1], self.v[-1], out)


def continuous_tracks(doc: dict[str, Any], emb: Embodiment) -> list[str]:
    return [
        d
        for d, keys in doc["tracks"].items()
        if emb.dof(d).type.value == "continuous"
        and keys
        and all(isinstance(k["v"], (int, float)) for k in keys)
    ]


def sampler(doc: dict[str, Any], dofs: list[str]):
    tracks = [_Track(doc["tracks"][d]) for d in dofs]

    def sample(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.stack([tr(t) for tr in tracks], axis=1)

    return sample


def analyse_clip(
    doc: dict[str, Any], emb: Embodiment, rate: float = 100.0, suggest: bool = True
) -> dict[str, Any]:
    """The limits section of the import report (see the module doc)."""
    dofs = continuous_tracks(doc, emb)
    duration = float(doc.get("duration", 0.0))
    out: dict[str, Any] = {"rate": rate, "dofs": {}, "ok": True, "fit_scale": 1.0, "nmf": None}
    if not dofs:
        return out
    sample = sampler(doc, dofs)
    n = math.floor(duration * rate + 1e-9) + 1
    t = np.arange(max(n, 2)) / rate
    x = sample(np.minimum(t, duration))
    d = [emb.dof(name) for name in dofs]
    vel = np.array([x.velocity for x in d])
    acc = np.array([x.acceleration for x in d])
    jerk = np.array([x.jerk for x in d])
    counts = trajectory.limit_counts(x, rate, vel, acc, jerk)
    out["dofs"] = dict(zip(dofs, counts))
    over = any(c["velocity"] or c["acceleration"] or c["jerk"] for c in counts)
    out["ok"] = not over
    if over and suggest:
        max_scale = min(MAX_SCALE, SEARCH_BUDGET / max(1.0, x.size))
        out["fit_scale"] = (
            trajectory.time_scale_to_fit(sample, duration, rate, vel, acc, jerk, max_scale=max_scale)
            if max_scale > 1.0
            else None
        )
        out["max_scale"] = round(max_scale, 3)
        fits = trajectory.preset_fit(
            x, rate, vel, acc, jerk, pmin=[q.min for q in d], pmax=[q.max for q in d]
        )
        best = fits[0]
        out["nmf"] = {
            "best": best["preset"],
            "meaning": best["meaning"],
            "rms_deg": math.degrees(best["rms"]),
            "max_deg": math.degrees(best["max"]),
            "ghost_ok": best["ghost_ok"],
            "presets": {
                f["preset"]: {
                    "rms_deg": round(math.degrees(f["rms"]), 4),
                    "max_deg": round(math.degrees(f["max"]), 4),
                }
                for f in fits
            },
        }
    elif over:
        out["fit_scale"] = None
    return out


def scale_clip_time(doc: dict[str, Any], s: float) -> None:
    """Play the clip `s` times slower: key times, handles' time offsets, events, anchors, duration."""
    for keys in doc["tracks"].values():
        for k in keys:
            k["t"] = _r(k["t"] * s)
            for side in ("left", "right"):
                if k.get(side):
                    k[side][0] = _r(k[side][0] * s)
                    k[side][1] = _r(k[side][1])
    for e in doc.get("events", []):
        e["t"] = _r(e["t"] * s)
    doc["anchors"] = {k: _r(v * s) for k, v in doc.get("anchors", {}).items()}
    if "duration" in doc:
        doc["duration"] = _r(doc["duration"] * s)


def _r(x: float) -> float:
    return round(float(x), 10) + 0.0
