"""A clip as the engine will play it, for a DCC tool's ghost and Check limits (POST /api/filter and
/api/analyze with a `clip`): the clip evaluated at the *engine's* rate by the playback code
(`CompiledClip.sample`, what a clip player writes each tick), judged or filtered there, and sampled back
at the scene's frames.

Why the engine's rate: the motion filter is a discrete-time system and finite differences depend on
the step, so a ghost filtered at 24 fps drifts from what the engine plays at 100 Hz, and a check at 24 fps
under-reads a jerk the engine sees (51x against 167x) or misses one.

Times: clip time t = 0 is the scene's first frame; engine tick j is at t = j / engine_rate and scene
frame k (from the scene's start frame) at t = k / scene_rate. Both run to the clip's duration; values
between two ticks are interpolated linearly (the robot moves between its frames).

Ranges (`clip_ranges`): every run of engine ticks where a DoF breaks any limit is one range, named by
the limit that breaks: position when the clip leaves the robot's range, otherwise the lowest-order
derivative over its limit (velocity before acceleration before jerk): a motion too fast also shows
as too much acceleration and jerk, and what the animator fixes is its timing. `limits` gives the worst
ratio of every limit broken in the range.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.engine import trajectory
from backend.engine.blocks.motion_filter import FilterParams
from backend.engine.clips import ClipError, CompiledClip, compile_clip
from backend.engine.embodiment import Embodiment
from backend.engine.track_analysis import TrackError, dof_summaries, filter_matrix

MAX_TICKS = 360_000  # an hour at 100 Hz: a longer clip is refused, not truncated
MAX_SCALE = 20.0
SEARCH_BUDGET = 4e6  # engine samples x DoFs one slow-down trial may take (a long clip searches less)
ORDER = ("velocity", "acceleration", "jerk")  # the derivatives, lowest order first


@dataclass
class EngineSamples:
    """A clip's continuous DoFs at the engine's rate: `x` (T, n), tick j at t = j / rate."""

    names: list[str]
    channels: np.ndarray  # (n,) channel of each DoF
    x: np.ndarray
    rate: float
    duration: float
    clip: CompiledClip
    curve_rows: np.ndarray  # (n,) the clip's curve of each DoF
    offsets: np.ndarray  # (n,) added to each curve's value (the rest value of a relative clip)

    def at(self, t: np.ndarray) -> np.ndarray:
        """The DoFs at clip times `t` (s, any order), (len(t), n), by the playback code."""
        evaluate = self.clip.curves.evaluate
        out = np.empty((len(t), len(self.names)))
        for j, tj in enumerate(np.asarray(t, dtype=float)):
            out[j] = evaluate(float(tj))[self.curve_rows]
        return out + self.offsets


def compile_for_preview(emb: Embodiment, doc: Any) -> CompiledClip:
    """The posted clip compiled against the robot; TrackError (field `clip...`) says why not."""
    if not isinstance(doc, dict):
        raise TrackError("clip must be a nutty-clip/1 document (a JSON object)", "clip")
    try:
        return compile_clip(doc, emb)
    except ClipError as exc:
        raise TrackError(f"clip: {exc}", "clip") from exc


def engine_samples(emb: Embodiment, doc: Any, rate: float) -> EngineSamples:
    """Every continuous DoF the clip keys, at each engine tick from t = 0 to its duration."""
    clip = compile_for_preview(emb, doc)
    continuous = emb.continuous_mask[clip.channels]
    rows = np.flatnonzero(continuous)
    if rows.size == 0:
        raise TrackError("clip: it keys no continuous DoF: nothing moves to check or filter", "clip.tracks")
    channels = clip.channels[rows]
    names = [emb.channel_names[c] for c in channels.tolist()]
    ticks = math.floor(clip.duration * rate + 1e-6) + 1
    if ticks > MAX_TICKS:
        raise TrackError(
            f"clip: {clip.duration:g} s is {ticks} ticks at {rate:g} Hz (at most {MAX_TICKS})",
            "clip.duration",
        )
    offsets = np.where(clip.relative[rows], emb.rest[channels], 0.0)
    s = EngineSamples(names, channels, np.empty((0, rows.size)), rate, clip.duration, clip, rows, offsets)
    s.x = s.at(np.arange(max(ticks, 2)) / rate)
    return s


def scene_times(duration: float, scene_rate: float) -> np.ndarray:
    """The clip times (s) of the scene's frames from its start: k / scene_rate, k = 0..floor(d * rate)."""
    # 1e-6 of a frame: a duration written with 9 decimals still reaches its last frame
    return np.arange(math.floor(duration * scene_rate + 1e-6) + 1) / scene_rate


def at_scene_frames(values: np.ndarray, rate: float, times: np.ndarray) -> np.ndarray:
    """Engine-rate values (T, n) at clip times `times`, linear between ticks, held after the last."""
    pos = np.clip(times * rate, 0.0, values.shape[0] - 1)
    j = np.minimum(np.floor(pos + 1e-9).astype(int), values.shape[0] - 1)
    nxt = np.minimum(j + 1, values.shape[0] - 1)
    w = np.clip(pos - j, 0.0, 1.0)[:, None]
    return values[j] * (1.0 - w) + values[nxt] * w


def _ratios(emb: Embodiment, s: EngineSamples) -> dict[str, np.ndarray]:
    """Each sample's |derivative| / limit per DoF, and its position's distance from mid-range over half
    the range (1 at a limit)."""
    ch = s.channels
    vel, acc, jerk = trajectory.derivatives(s.x, s.rate)
    lo, hi = emb.min[ch], emb.max[ch]
    return {
        "velocity": np.abs(vel) / emb.vel_limit[ch],
        "acceleration": np.abs(acc) / emb.acc_limit[ch],
        "jerk": np.abs(jerk) / emb.jerk_limit[ch],
        "position": np.abs(s.x - (hi + lo) / 2.0) / np.maximum((hi - lo) / 2.0, 1e-12),
    }


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of every run of True."""
    padded = np.r_[False, flags, False].astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def _scene_frame(tick: int, rate: float, scene_rate: float, last: int, up: bool) -> int:
    """The scene frame (from the start frame) of an engine tick, rounded down or up, at most `last`."""
    f = tick * scene_rate / rate
    return min(math.ceil(f - 1e-9) if up else math.floor(f + 1e-9), last)


def _range(
    dof: str, ratios: dict[str, np.ndarray], i: int, span: tuple[int, int], rate: float, scene_rate: float
) -> dict[str, Any]:
    """One run of ticks [a, b] where DoF column `i` breaks a limit, as a LimitRange."""
    a, b = span
    broken = {
        k: float(r[a : b + 1, i].max()) for k, r in ratios.items() if (r[a : b + 1, i] > 1 + 1e-9).any()
    }
    kind = "position" if "position" in broken else next(k for k in ORDER if k in broken)
    worst = a + int(np.argmax(ratios[kind][a : b + 1, i]))
    last = math.floor((ratios["velocity"].shape[0] - 1) * scene_rate / rate + 1e-9)
    return {
        "dof": dof,
        "kind": kind,
        "start": _scene_frame(a, rate, scene_rate, last, up=False),
        "end": _scene_frame(b, rate, scene_rate, last, up=True),
        "worst_ratio": broken[kind],
        "worst_sample": min(round(worst * scene_rate / rate), last),
        "t_start": a / rate,
        "t_end": b / rate,
        "limits": broken,
    }


def clip_ranges(emb: Embodiment, s: EngineSamples, scene_rate: float) -> list[dict[str, Any]]:
    """The ranges where the clip breaks a limit at the engine's rate (see the module doc), with their
    scene frames (indices from the scene's start frame, rounded outwards)."""
    ratios = _ratios(emb, s)
    over = np.zeros(s.x.shape, dtype=bool)
    for r in ratios.values():
        over |= r > 1 + 1e-9
    out = [
        _range(name, ratios, i, span, s.rate, scene_rate)
        for i, name in enumerate(s.names)
        for span in _runs(over[:, i])
    ]
    out.sort(key=lambda r: (r["start"], r["dof"]))
    return out


def slow_down(emb: Embodiment, s: EngineSamples) -> tuple[float | None, float]:
    """(the smallest uniform slow-down >= 1 that brings every velocity, acceleration and jerk within its
    limit at the engine's rate, or None when none up to the searched maximum does; that maximum)."""
    ch = s.channels
    max_scale = min(MAX_SCALE, SEARCH_BUDGET / max(1.0, s.x.size))
    if max_scale <= 1.0:
        return None, max_scale
    scale = trajectory.time_scale_to_fit(
        s.at,
        s.duration,
        s.rate,
        emb.vel_limit[ch],
        emb.acc_limit[ch],
        emb.jerk_limit[ch],
        max_scale=max_scale,
    )
    return scale, max_scale


def suggestion(ranges: list[dict[str, Any]], scale: float | None, max_scale: float, duration: float) -> str:
    """One line for the animator: what would bring the clip within the robot's limits."""
    if not ranges:
        return "within every limit at the engine's rate"
    outside = sorted({r["dof"] for r in ranges if r["kind"] == "position"})
    if outside:
        return (
            f"{', '.join(outside)} leave{'s' if len(outside) == 1 else ''} the robot's range: "
            f"bring the keys within the limits (no slow-down fixes a position)"
        )
    if scale is None:
        return f"no slow-down up to {max_scale:.3g}x fits: ease the fastest keys or filter the motion"
    return (
        f"play it {scale:.3g}x slower ({duration:.3g} s -> {duration * scale:.3g} s) to fit every limit "
        f"(nutty import --fit-limits does the same)"
    )


def analyze_clip(
    emb: Embodiment, engine_rate: float, doc: Any, scene_rate: float, fit: bool = True
) -> dict[str, Any]:
    """The trajectory-helper's verdict on a clip at the engine's rate, answered at the scene's frames
    (POST /api/analyze with a clip): ranges, per-DoF summaries at the engine's rate, the slow-down
    that fits and a one-line suggestion. `fit=False` leaves out the slow-down search (`fit_scale` null),
    which costs most of the time (~100 ms of ~105 for a 2.7 s clip over its limits): the clip editor
    colours every edit without it and asks for the fit once the edits pause."""
    s = engine_samples(emb, doc, engine_rate)
    _, dofs = dof_summaries(emb, s.names, s.x, s.channels, s.rate)
    ranges = clip_ranges(emb, s, scene_rate)
    if not fit:
        scale, max_scale = None, MAX_SCALE
    else:
        scale, max_scale = slow_down(emb, s) if ranges else (1.0, MAX_SCALE)
    if any(r["kind"] == "position" for r in ranges):
        scale = None  # no slow-down brings a position back within the range
    return {
        "rate": scene_rate,
        "engine_rate": s.rate,
        "samples": scene_times(s.duration, scene_rate).size,
        "ok": not ranges,
        "ranges": ranges,
        "dofs": dofs,
        "colours": dict(trajectory.CLASS_COLOURS),
        "fit_scale": scale,
        "max_scale": round(max_scale, 3),
        "suggestion": suggestion(ranges, scale, max_scale, s.duration) if fit else None,
    }


def filter_clip(
    emb: Embodiment, engine_rate: float, doc: Any, scene_rate: float, params: FilterParams
) -> tuple[float, dict[str, list[float]]]:
    """(the engine's rate, the clip's continuous DoFs through the stage-2 filter `params` at that rate,
    started at rest on the clip's first values, sampled at the scene's frames)."""
    s = engine_samples(emb, doc, engine_rate)
    out = filter_matrix(emb, s.rate, s.x, s.channels, params)
    frames = at_scene_frames(out, s.rate, scene_times(s.duration, scene_rate))
    return s.rate, {name: frames[:, i].tolist() for i, name in enumerate(s.names)}


def warm_up(emb: Embodiment, engine_rate: float) -> float:
    """Compile what the first ghost and check would otherwise compile on request (the motion filter's
    whole-trajectory kernel and the curve evaluation: seconds on a cold cache), on a tiny clip of the
    robot's first continuous DoF. Returns the seconds it took; 0 for a robot with nothing to filter."""
    names = [d.name for d in emb.dofs if d.type.value == "continuous"]
    if not names:
        return 0.0
    start = time.perf_counter()
    doc = {
        "format": "nutty-clip/1",
        "name": "warm_up",
        "tracks": {names[0]: [{"t": 0.0, "v": 0.0, "interp": "bezier"}, {"t": 0.1, "v": 0.0}]},
    }
    filter_clip(emb, engine_rate, doc, 24.0, FilterParams(preset="D"))
    analyze_clip(emb, engine_rate, doc, 24.0)
    return time.perf_counter() - start
