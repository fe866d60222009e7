"""The trajectory-helper and the ghost for sampled tracks a client posts (POST /api/analyze, /api/filter):
a DCC tool samples its animation (one value per frame per DoF) and asks where it breaks the robot's
limits, and what the Nutty Motion Filter would make of it.

Tracks are `{dof: [value, ...]}` on continuous DoFs (rad or m), all the same length, sampled at `rate`
Hz from sample 0. `analyze_tracks` classifies every sample with `backend.engine.trajectory.analyze`
(the editor's rule: backward finite differences, the trajectory taken to start at rest, the most
severe class wins: position > jerk > acceleration > velocity) and groups consecutive samples of one
class into *ranges*, each with its worst ratio to the limit (|derivative| / limit; for position the
distance from the middle of the range over half the range, so 1 is at the limit). `filter_tracks` runs
the tracks through the robot's stage-2 motion filter (`nmf_stage2`, its limits and character) from the
first sample, at the tracks' rate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine import trajectory
from backend.engine.blocks.base import BlockContext
from backend.engine.blocks.motion_filter import MotionFilterStage2, Stage2Params
from backend.engine.embodiment import DofType, Embodiment

if TYPE_CHECKING:
    from backend.engine.blocks.motion_filter import FilterParams

MAX_SAMPLES = 200_000  # per track (an hour at 50 Hz); a longer request is refused, not truncated


class TrackError(ValueError):
    """Posted tracks that do not fit the robot; `field` names the track (`tracks.<dof>`)."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


def _matrix(emb: Embodiment, tracks: dict[str, list[float]]) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(names, samples (T, n), channel index (n,)); TrackError names the first track that does not fit."""
    if not tracks:
        raise TrackError("no tracks: send at least one {dof: [values]}", "tracks")
    names = list(tracks)
    length = len(tracks[names[0]])
    for name, values in tracks.items():
        field = f"tracks.{name}"
        if not emb.has_dof(name):
            raise TrackError(f"robot '{emb.name}' has no DoF '{name}'", field)
        dof = emb.dof(name)
        if dof.type is not DofType.continuous:
            raise TrackError(
                f"DoF '{name}' is not continuous ({dof.type.value}): only continuous DoFs have "
                f"limits to check",
                field,
            )
        if not values:
            raise TrackError(f"track '{name}' has no samples", field)
        if len(values) > MAX_SAMPLES:
            raise TrackError(f"track '{name}' has {len(values)} samples (at most {MAX_SAMPLES})", field)
        if len(values) != length:
            raise TrackError(
                f"track '{name}' has {len(values)} samples, track '{names[0]}' {length}: "
                f"every track needs one value per sample",
                field,
            )
    x = np.array([tracks[n] for n in names], dtype=float).T
    channels = np.array([emb.dof(n).channels.start for n in names])
    return names, x, channels


def _runs(codes: np.ndarray) -> list[tuple[int, int, int]]:
    """(first, last, code) of every run of equal non-zero codes."""
    edges = np.flatnonzero(np.diff(codes)) + 1
    starts = np.r_[0, edges]
    ends = np.r_[edges, codes.size] - 1
    return [(int(a), int(b), int(codes[a])) for a, b in zip(starts, ends) if codes[a] != trajectory.OK]


def dof_summaries(
    emb: Embodiment, names: list[str], x: np.ndarray, ch: np.ndarray, rate: float
) -> tuple[trajectory.Analysis, dict[str, Any]]:
    """The trajectory-helper's classes of samples `x` (T, n) of DoFs `names` (channels `ch`) at `rate`
    Hz, and per DoF its peaks, its samples per class and its limits."""
    vel, acc, jerk = emb.vel_limit[ch], emb.acc_limit[ch], emb.jerk_limit[ch]
    lo, hi = emb.min[ch], emb.max[ch]
    result = trajectory.analyze(x, rate, vel, acc, jerk, lo, hi)
    dofs: dict[str, Any] = {}
    for i, name in enumerate(names):
        summary = result.summary[i]
        dofs[name] = {
            **{k: summary[k] for k in ("max_velocity", "max_acceleration", "max_jerk")},
            "counts": {k: summary[k] for k in trajectory.CLASS_NAMES.values()},
            "limits": {
                "min": float(lo[i]),
                "max": float(hi[i]),
                "velocity": float(vel[i]),
                "acceleration": float(acc[i]),
                "jerk": float(jerk[i]),
            },
        }
    return result, dofs


def analyze_tracks(emb: Embodiment, rate: float, tracks: dict[str, list[float]]) -> dict[str, Any]:
    """The trajectory-helper's verdict on posted tracks (see the module doc)."""
    names, x, ch = _matrix(emb, tracks)
    result, dofs = dof_summaries(emb, names, x, ch, rate)
    lo, hi = emb.min[ch], emb.max[ch]
    centre, half = (hi + lo) / 2.0, np.maximum((hi - lo) / 2.0, 1e-12)
    ratios = {
        trajectory.VELOCITY: np.abs(result.velocity) / emb.vel_limit[ch],
        trajectory.ACCELERATION: np.abs(result.acceleration) / emb.acc_limit[ch],
        trajectory.JERK: np.abs(result.jerk) / emb.jerk_limit[ch],
        trajectory.POSITION: np.abs(x - centre) / half,
    }
    ranges: list[dict[str, Any]] = []
    for i, name in enumerate(names):
        for first, last, code in _runs(result.classes[:, i]):
            ratio = ratios[code][first : last + 1, i]
            worst = int(np.argmax(ratio))
            kind = trajectory.CLASS_NAMES[code]
            ranges.append(
                {
                    "dof": name,
                    "kind": kind,
                    "start": first,
                    "end": last,
                    "worst_ratio": float(ratio[worst]),
                    "worst_sample": first + worst,
                    "t_start": first / rate,
                    "t_end": last / rate,
                    "limits": {kind: float(ratio[worst])},
                }
            )
    ranges.sort(key=lambda r: (r["start"], r["dof"]))
    return {
        "rate": rate,
        "engine_rate": rate,
        "samples": int(x.shape[0]),
        "ok": result.ok,
        "ranges": ranges,
        "dofs": dofs,
        "colours": dict(trajectory.CLASS_COLOURS),
    }


def filter_tracks(
    emb: Embodiment, rate: float, tracks: dict[str, list[float]], params: FilterParams
) -> dict[str, list[float]]:
    """The tracks after the stage-2 motion filter with `params` (an `nmf_stage2` block's FilterParams),
    started at rest on the first sample; DoFs not posted hold their rest values."""
    names, x, ch = _matrix(emb, tracks)
    out = filter_matrix(emb, rate, x, ch, params)
    return {name: out[:, i].tolist() for i, name in enumerate(names)}


def filter_matrix(
    emb: Embodiment, rate: float, x: np.ndarray, ch: np.ndarray, params: FilterParams
) -> np.ndarray:
    """Samples `x` (T, n) of channels `ch` at `rate` Hz through the stage-2 motion filter (see
    `filter_tracks`), as a (T, n) array."""
    # the robot's limits, as the engine sets them (a program's stage 2 may skip DoFs: its params say)
    stage2_params = params if isinstance(params, Stage2Params) else Stage2Params(**params.model_dump())
    stage2 = MotionFilterStage2(stage2_params, BlockContext(emb, rate))
    mf = stage2.filter
    if mf is None:  # nothing to filter (not so while a continuous DoF is posted): the samples as given
        return x.copy()
    # the posted channels the engine's stage 2 filters (others pass as the engine passes them)
    inside = np.isin(ch, stage2.idx)
    where = np.searchsorted(stage2.idx, ch[inside])
    start = emb.rest[stage2.idx].copy()
    start[where] = x[0, inside]
    mf.reset(start)
    setpoints = np.full((x.shape[0], stage2.idx.size), np.nan)  # NaN: the other channels hold
    setpoints[:, where] = x[:, inside]
    out = x.copy()
    # tick by tick through the engine's own step (already compiled by a running stage 2), not the
    # whole-trajectory kernel, which would compile on a server's first ghost: same arithmetic
    filtered = np.empty_like(setpoints)
    step = mf.step
    for k in range(setpoints.shape[0]):
        filtered[k] = step(setpoints[k])
    out[:, inside] = filtered[:, where]
    return out
