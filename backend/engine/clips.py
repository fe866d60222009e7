"""Keyframed clips: the JSON format (`nutty-clip/1`) and its compiled, vectorised form.

A clip is a set of tracks, one per DoF, each a list of keyframes (see `backend.engine.curves`), plus
*anchors* (named marks in clip time that a play command can warp to given times, so a gesture's beat
lands on a word) and timed *events* (speech, sounds). Stored as `robots/<name>/clips/<clip>.json`:

    {"format": "nutty-clip/1", "name": "nod", "duration": 1.2,
     "tracks": {"head_pitch": [{"t": 0, "v": 0}, {"t": 0.3, "v": 0.25}, {"t": 1.2, "v": 0}]},
     "anchors": {"down": 0.3},
     "events": [{"t": 0.3, "dof": "sound", "kind": "sound", "payload": {"clip": "chirp"}}]}

Values: continuous DoFs take numbers (rad or m; offsets from the rest pose if `relative`), colour DoFs
`[r, g, b]` in 0..1, enum DoFs an option name (enum and colour-free keys always step or blend linearly).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from backend.engine.asset_errors import LibraryError
from backend.engine.curves import CurveSet, EasingMode, HandleType, Interp, Key
from backend.engine.embodiment import DofType, Embodiment
from backend.engine.frames import FrameEvent

CLIP_FORMAT = "nutty-clip/1"


class ClipError(ValueError):
    """A clip that does not fit the robot or is malformed; the message names the track and key, and
    `field` is its path in the document (`tracks.head_pitch.2.v`, `events.0.dof`), when known."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Keyframe(_Model):
    """One key of a track. `interp` shapes the segment that leaves this key."""

    t: float = Field(..., ge=0.0, le=3600.0, description="time in the clip (s)")
    v: float | str | list[float] = Field(..., description="value: rad/m, option name, or [r, g, b]")
    interp: Interp = Field(default="bezier", description="constant, linear, bezier or an easing preset")
    easing: EasingMode = Field(default="in_out", description="for easing presets: in, out or in_out")
    left_type: HandleType = Field(default="auto_clamped", description="type of the handle before the key")
    right_type: HandleType = Field(default="auto_clamped", description="type of the handle after the key")
    left: tuple[float, float] | None = Field(default=None, description="left handle offset [dt <= 0 s, dv]")
    right: tuple[float, float] | None = Field(default=None, description="right handle offset [dt >= 0 s, dv]")

    @field_validator("v")
    @classmethod
    def _finite(cls, v: Any) -> Any:
        nums = v if isinstance(v, list) else [v] if isinstance(v, float) else []
        if any(not math.isfinite(x) for x in nums):
            raise ValueError("values must be finite numbers")
        return v

    @field_validator("left", "right")
    @classmethod
    def _finite_handle(cls, h: tuple[float, float] | None) -> tuple[float, float] | None:
        if h is not None and not all(math.isfinite(x) for x in h):
            raise ValueError("handle offsets must be finite numbers")
        return h


class ClipEvent(_Model):
    t: float = Field(..., ge=0.0, description="time in the clip (s)")
    dof: str = Field(..., min_length=1, description="event DoF (speech, sound) or display DoF")
    kind: str = Field(..., min_length=1, description="say, sound, expression, ...")
    payload: dict[str, Any] = Field(default_factory=dict)


class Clip(_Model):
    """A keyframed clip (`nutty-clip/1`)."""

    format: Literal["nutty-clip/1"] = CLIP_FORMAT
    name: str = Field(default="", max_length=80)
    description: str = ""
    robot: str | None = Field(default=None, description="robot the clip was authored for (informative)")
    duration: float | None = Field(
        default=None, gt=0.0, le=3600.0, description="length (s); default: the last key"
    )
    relative: bool = Field(default=False, description="continuous values are offsets from the rest pose")
    fps: float | None = Field(
        default=None,
        ge=1.0,
        le=1000.0,
        description="frame rate the clip is authored at (frames/s): editors snap keys to its frames "
        "(default 30); playback is continuous and ignores it",
    )
    tracks: dict[str, list[Keyframe]] = Field(..., description="DoF name -> keys in increasing time")
    anchors: dict[str, float] = Field(default_factory=dict, description="anchor name -> clip time (s)")
    events: list[ClipEvent] = Field(default_factory=list)
    source: dict[str, Any] = Field(default_factory=dict, description="where an imported clip came from")

    @model_validator(mode="after")
    def _check(self) -> Clip:
        if not self.tracks:
            raise ClipError("a clip needs at least one track", "tracks")
        for dof, keys in self.tracks.items():
            if not keys:
                raise ClipError(f"track '{dof}' has no keys", f"tracks.{dof}")
            times = [k.t for k in keys]
            for i, (a, b) in enumerate(zip(times, times[1:])):
                if b <= a:
                    raise ClipError(
                        f"track '{dof}': key times must increase strictly ({a} then {b})",
                        f"tracks.{dof}.{i + 1}.t",
                    )
        end = self.length
        for name, t in self.anchors.items():
            if not 0.0 <= t <= end:
                raise ClipError(
                    f"anchor '{name}' at {t} s is outside the clip (0..{end} s)", f"anchors.{name}"
                )
        return self

    @property
    def length(self) -> float:
        last = max(keys[-1].t for keys in self.tracks.values())
        return float(self.duration) if self.duration is not None else float(last)


def clip_json_schema() -> dict[str, Any]:
    """JSON Schema of the clip format, for the editor's generated types (`nutty schema`)."""
    return Clip.model_json_schema()


def first_clip_error(exc: ValidationError) -> tuple[str, str | None]:
    """The first error of a clip's validation as (message, field path): a field pydantic names, or
    the one a whole-clip check (`Clip._check`) raised with its ClipError."""
    first = exc.errors()[0]
    cause = (first.get("ctx") or {}).get("error")
    if isinstance(cause, ClipError):
        return f"invalid clip: {cause}", cause.field
    where = ".".join(str(p) for p in first["loc"])
    return f"invalid clip: {where}: {first['msg']}", where or None


def validate_clip_doc(doc: dict[str, Any]) -> dict[str, Any]:
    """The library's validator: a normalised clip document, or LibraryError naming the field."""
    try:
        return Clip.model_validate(doc).model_dump(mode="json", exclude_none=True)
    except ValidationError as exc:
        message, field = first_clip_error(exc)
        raise LibraryError(message, field) from exc


@dataclass
class CompiledClip:
    """A clip resolved against a robot: channel curves evaluated in one vectorised call."""

    name: str
    duration: float
    channels: np.ndarray  # (K,) channel index of each curve
    curves: CurveSet
    mask: np.ndarray  # (C,) channels the clip sets
    relative: np.ndarray  # (K,) bool: add the rest value
    enum_curves: np.ndarray  # (K,) bool: round to an option index
    anchors: dict[str, float]
    events: list[tuple[float, FrameEvent]]

    def __post_init__(self) -> None:
        self.any_relative = bool(np.any(self.relative))  # a relative clip fades its offsets by the envelope
        self.event_times = np.array([t for t, _ in self.events], dtype=float)  # (E,) s, for the compiled core
        self.scratch = np.empty(len(self.channels))  # (K,) the curves' values, written by the compiled core

    def sample(self, t: float, rest: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Write the clip's values at clip time `t` (s) into `out` (a full channel vector)."""
        vals = self.curves.evaluate(t)
        vals = np.where(self.relative, vals + rest[self.channels], vals)
        vals = np.where(self.enum_curves, np.round(vals), vals)
        out[self.channels] = vals
        return out


def compile_clip(clip: Clip | dict[str, Any], emb: Embodiment) -> CompiledClip:
    """Resolve a clip's tracks to the robot's channels; ClipError names the first track that fails."""
    if not isinstance(clip, Clip):
        try:
            clip = Clip.model_validate(clip)
        except ValidationError as exc:
            raise ClipError(*first_clip_error(exc)) from exc
    channels: list[int] = []
    curves: list[list[Key]] = []
    relative: list[bool] = []
    enum_flags: list[bool] = []
    for dof_name, keys in clip.tracks.items():
        if not emb.has_dof(dof_name):
            raise ClipError(
                f"track '{dof_name}': robot '{emb.name}' has no DoF '{dof_name}'", f"tracks.{dof_name}"
            )
        dof = emb.dof(dof_name)
        sl = dof.channels
        if dof.type is DofType.event:
            raise ClipError(
                f"track '{dof_name}': event DoFs take clip events, not keys", f"tracks.{dof_name}"
            )
        width = sl.stop - sl.start
        per_channel: list[list[Key]] = [[] for _ in range(width)]
        for n, k in enumerate(keys):
            vals = _key_values(dof, k.v, f"track '{dof_name}' key {n}", f"tracks.{dof_name}.{n}.v")
            interp = "constant" if dof.type is DofType.enum else k.interp
            if dof.type is DofType.colour and interp == "bezier":
                interp = "linear"
            for c in range(width):
                per_channel[c].append(
                    Key(
                        k.t,
                        vals[c],
                        interp,
                        k.easing,
                        k.left_type,
                        k.right_type,
                        k.left,  # validated: a (dt, dv) tuple or None
                        k.right,
                    )
                )
        for c in range(width):
            channels.append(sl.start + c)
            curves.append(per_channel[c])
            relative.append(clip.relative and dof.type is DofType.continuous)
            enum_flags.append(dof.type is DofType.enum)
    events: list[tuple[float, FrameEvent]] = []
    for n, e in enumerate(clip.events):
        if not emb.has_dof(e.dof):
            raise ClipError(f"event {n}: robot '{emb.name}' has no DoF '{e.dof}'", f"events.{n}.dof")
        events.append((e.t, FrameEvent(e.dof, e.kind, dict(e.payload))))
    events.sort(key=lambda item: item[0])
    try:
        curve_set = CurveSet(curves)
    except ValueError as exc:
        raise ClipError(str(exc)) from exc
    mask = np.zeros(emb.n_channels, dtype=bool)
    mask[channels] = True
    return CompiledClip(
        clip.name,
        clip.length,
        np.array(channels),
        curve_set,
        mask,
        np.array(relative),
        np.array(enum_flags),
        dict(clip.anchors),
        events,
    )


def _key_values(dof, v: Any, where: str, field: str) -> list[float]:
    if dof.type is DofType.continuous:
        if not isinstance(v, (int, float)):
            raise ClipError(f"{where}: DoF '{dof.name}' takes a number, got {v!r}", field)
        return [float(v)]
    if dof.type is DofType.colour:
        if not isinstance(v, list) or len(v) != 3:
            raise ClipError(f"{where}: DoF '{dof.name}' takes a colour [r, g, b], got {v!r}", field)
        return [min(max(float(x), 0.0), 1.0) for x in v]
    options = list(dof.options or ())
    if isinstance(v, str):
        if v not in options:
            raise ClipError(f"{where}: DoF '{dof.name}' has no option '{v}' (one of {options})", field)
        return [float(options.index(v))]
    if isinstance(v, (int, float)) and 0 <= int(v) < len(options):
        return [float(int(v))]
    raise ClipError(f"{where}: DoF '{dof.name}' takes one of {options}, got {v!r}", field)


def time_map(
    duration: float, speed: float, anchors: dict[str, float], targets: dict[str, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear map from playback time to clip time that lands each anchor at its target.

    `anchors` are clip times (s) of named marks, `targets` the playback times (s) they must meet.
    Outside the anchored span the clip plays at `speed`. Raises ClipError for unknown anchors or
    targets that would make time run backwards.
    """
    pts = [(0.0, 0.0)]
    for name in sorted(targets, key=lambda n: anchors.get(n, -1.0)):
        if name not in anchors:
            raise ClipError(f"clip has no anchor '{name}' (anchors: {sorted(anchors)})")
        tt = float(targets[name])
        if not math.isfinite(tt) or tt < 0:
            raise ClipError(f"anchor '{name}': target time must be a finite number >= 0, got {tt}")
        ct = anchors[name]
        if tt <= pts[-1][0] and ct > pts[-1][1]:
            raise ClipError(
                f"anchor '{name}' cannot land at {tt} s: it comes after an anchor landing at {pts[-1][0]} s"
            )
        pts.append((tt, ct))
    play_end = pts[-1][0] + (duration - pts[-1][1]) / speed
    pts.append((max(play_end, pts[-1][0]), duration))
    play, clip = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
    return play, clip
