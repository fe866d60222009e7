"""The clip player: plays keyframed clips from the robot's library, live and steerable."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field

from backend.engine.blocks.base import Block, BlockCommandError, BlockParams, DofSelection, Port, PortType, Role, register_block
from backend.engine.clips import ClipError, CompiledClip, compile_clip, time_map
from backend.engine.frames import FrameEvent, PartialFrame
from backend.engine.selectors import channel_mask

PlayMode = Literal["once", "loop", "ping_pong"]


class ClipPlayerParams(BlockParams):
    clip: str | None = Field(None, description="clip to play (from robots/<robot>/clips/)",
                             json_schema_extra={"x-widget": "clip"})
    autoplay: bool = Field(False, description="start playing `clip` when the program starts")
    mode: PlayMode = Field("once", description="once, loop, or ping_pong (forward then backward)")
    speed: float = Field(1.0, ge=0.05, le=5.0, description="playback speed (1 = authored timing)")
    crossfade: float = Field(0.3, ge=0.0, le=5.0, description="blend-in time from the current pose (s)")
    release: float = Field(0.4, ge=0.0, le=5.0, description="blend-out time after the clip ends or stops (s)")
    hold: bool = Field(False, description="after a `once` clip ends, hold its last pose instead of releasing")
    dofs: DofSelection = Field(default=["*"], description="DoFs the clip may set (others are ignored)")


def _smooth(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


@register_block
class ClipPlayer(Block):
    """Plays keyframed clips (per-DoF animation curves) once, looped or ping-pong, at any speed.

    Commands: `play {clip, speed?, mode?, crossfade?, anchors?}`, `stop {fade?}`, `seek {t}`. A new clip
    crossfades from the pose the player shows now; `anchors` warp the clip's named marks to given times
    after the start (a beat meets a word). Clip events (speech, sounds) fire as the playhead passes them.
    Reports started, completed and cancelled with the command's id. The `weight` output is the blend
    envelope (0..1): wire it to the layer mixer's `<layer>_weight` port so the gesture layer fades in over
    `crossfade` and out over `release`; a `relative` clip also fades its offsets itself.
    """

    type_name = "clip_player"
    title = "Clip player"
    category = "sources"
    role = Role.source
    Params = ClipPlayerParams
    inputs = {
        "speed": Port(PortType.float, "overrides the speed (e.g. from an emotion mapping)"),
        "trigger": Port(PortType.bool, "a rising edge plays `clip`"),
    }
    outputs = {
        "out": Port(PortType.frame, "the clip's pose on its DoFs"),
        "weight": Port(PortType.float, "blend envelope 0..1 (wire to the mixer's layer weight)"),
        "playing": Port(PortType.bool, "true while a clip plays"),
        "time": Port(PortType.float, "clip time (s)"),
    }
    state_attrs = ("current", "pos", "play_t", "direction", "env", "env_target", "values", "from_values",
                   "xfade_t", "xfade", "mask", "old_mask", "command_id", "last_trigger", "warp", "speed",
                   "mode", "done", "fade_in", "fade_out", "pending_autoplay")

    def configure(self) -> None:
        self.allowed = channel_mask(self.emb, self.params.dofs)
        self._cache: dict[str, tuple[int, CompiledClip]] = {}
        if self.params.clip and self.ctx.resources is not None:
            self._load(self.params.clip)  # an unknown or broken clip is a configuration error, named

    def reset(self) -> None:
        n = self.emb.n_channels
        self.current: CompiledClip | None = None
        self.pos = 0.0  # clip time (s)
        self.play_t = 0.0  # time since play (s)
        self.direction = 1.0
        self.env = 0.0
        self.env_target = 0.0
        self.values = self.emb.rest.copy()
        self.from_values = self.emb.rest.copy()
        self.xfade_t = 0.0
        self.xfade = 0.0
        self.mask = np.zeros(n, dtype=bool)
        self.old_mask = np.zeros(n, dtype=bool)
        self.command_id = None
        self.last_trigger = False
        self.warp: tuple[np.ndarray, np.ndarray] | None = None
        self.speed: float | None = None
        self.mode: str = self.params.mode
        self.done = False
        self.fade_in = self.params.crossfade
        self.fade_out = self.params.release
        self.pending_autoplay = bool(self.params.autoplay and self.params.clip)

    # --- clips --------------------------------------------------------------------------------------
    def _load(self, name: str) -> CompiledClip:
        lib = self.ctx.resources
        if lib is None:
            raise BlockCommandError("no clip library is attached to this engine")
        try:
            doc = lib.get("clips", name)
        except ValueError as exc:  # LibraryError / NotFound
            raise BlockCommandError(f"clip '{name}': {exc}") from exc
        cached = self._cache.get(name)
        if cached is not None and cached[0] == id(doc):
            return cached[1]
        try:
            compiled = compile_clip(doc, self.emb)
        except ClipError as exc:
            raise BlockCommandError(f"clip '{name}': {exc}") from exc
        compiled.mask &= self.allowed
        self._cache[name] = (id(doc), compiled)
        return compiled

    def _start(self, name: str, args: dict[str, Any]) -> dict[str, Any]:
        clip = self._load(name)
        mode = str(args.get("mode") or self.params.mode)
        if mode not in ("once", "loop", "ping_pong"):
            raise BlockCommandError(f"mode must be once, loop or ping_pong, got '{mode}'")
        speed = args.get("speed")
        if speed is not None and not (isinstance(speed, (int, float)) and 0.05 <= speed <= 5.0):
            raise BlockCommandError(f"speed must be within [0.05, 5], got {speed!r}")
        warp = None
        if args.get("anchors"):
            try:
                warp = time_map(clip.duration, float(speed or self.params.speed), clip.anchors, dict(args["anchors"]))
            except ClipError as exc:
                raise BlockCommandError(f"clip '{name}': {exc}") from exc
        crossfade = args.get("crossfade")
        crossfade = self.params.crossfade if crossfade is None else float(crossfade)
        if self.current is not None and not self.done:
            self.ctx.notify(self.node_id, "cancelled", command_id=self.command_id, clip=self.current.name)
        # A clip replacing a visible one crossfades from the shown pose; from nothing, the envelope fades in.
        self.from_values = self.values.copy()
        self.old_mask = self.mask & (self.env > 0.0)
        self.xfade = crossfade if self.env > 0.0 else 0.0
        self.xfade_t = 0.0
        self.current, self.mode, self.speed, self.warp = clip, mode, speed, warp
        self.pos, self.play_t, self.direction, self.done = 0.0, 0.0, 1.0, False
        self.env_target = 1.0
        self.fade_in = crossfade
        self.mask = clip.mask.copy()
        self.command_id = args.get("command_id")
        self.ctx.notify(self.node_id, "started", command_id=self.command_id, clip=name, duration=clip.duration)
        return {"clip": name, "duration": clip.duration, "mode": mode}

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "play":
            name = args.get("clip") or self.params.clip
            if not name:
                raise BlockCommandError(f"clip player '{self.node_id}' has no clip to play: give 'clip'")
            return self._start(str(name), args)
        if command == "stop":
            if self.current is None or self.done:
                return {"stopped": False}
            self.ctx.notify(self.node_id, "cancelled", command_id=self.command_id, clip=self.current.name)
            self._finish(args.get("fade"))
            return {"stopped": True}
        if command == "seek":
            if self.current is None:
                raise BlockCommandError(f"clip player '{self.node_id}' is not playing a clip")
            t = float(args.get("t", 0.0))
            if not 0.0 <= t <= self.current.duration:
                raise BlockCommandError(f"seek time {t} s is outside the clip (0..{self.current.duration} s)")
            self.pos, self.warp = t, None  # a seek leaves any anchor warp behind
            return {"t": t}
        return super().handle(command, args)

    def _finish(self, fade: float | None = None) -> None:
        self.done = True
        self.env_target = 0.0
        self.fade_out = self.params.release if fade is None else float(fade)

    # --- tick ---------------------------------------------------------------------------------------
    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        trigger = bool(inputs.get("trigger") or False)
        if self.pending_autoplay or (trigger and not self.last_trigger and self.params.clip):
            self.pending_autoplay = False
            try:
                self._start(self.params.clip, {})
            except BlockCommandError as exc:
                self.ctx.notify(self.node_id, "error", message=str(exc))
        self.last_trigger = trigger
        clip = self.current
        events: list[FrameEvent] = []
        if clip is not None:
            if not self.done:
                events = self._advance(clip, dt, float(self.signal(inputs, "speed", self.speed or self.params.speed)))
            clip.sample(self.pos, self.emb.rest, self.values)
            if self.xfade_t < self.xfade:
                self.xfade_t += dt
                k = _smooth(self.xfade_t / self.xfade)
                self.values = np.where(self.old_mask & ~self.mask, self.from_values,
                                       self.from_values + k * (self.values - self.from_values))
            self._advance_envelope(dt)
            if self.done and self.env <= 0.0:
                self.current = None
        weight = _smooth(self.env)
        visible = self.current is not None or self.env > 0.0
        mask = (self.mask | (self.old_mask if self.xfade_t < self.xfade else False)) if visible else np.zeros_like(self.mask)
        values = self.values
        if clip is not None and clip.relative.any():
            rest = self.emb.rest
            values = rest + weight * (values - rest)
        return {"out": PartialFrame(values.copy(), mask, events), "weight": weight,
                "playing": self.current is not None and not self.done, "time": self.pos}

    def _advance_envelope(self, dt: float) -> None:
        if self.env < self.env_target:
            rate = 1.0 / self.fade_in if self.fade_in > 0 else math.inf
            self.env = min(self.env_target, self.env + rate * dt)
        elif self.env > self.env_target:
            rate = 1.0 / self.fade_out if self.fade_out > 0 else math.inf
            self.env = max(self.env_target, self.env - rate * dt)

    def _advance(self, clip: CompiledClip, dt: float, speed: float) -> list[FrameEvent]:
        before = self.pos
        duration = clip.duration
        self.play_t += dt
        wrapped = False
        if self.warp is not None and self.mode == "once":
            self.pos = float(np.interp(self.play_t, *self.warp))
        else:
            self.pos += self.direction * speed * dt
        if self.mode == "once":
            if self.pos >= duration:
                self.pos = duration
                events = self._events_between(clip, before, duration)
                self.ctx.notify(self.node_id, "completed", command_id=self.command_id, clip=clip.name)
                if self.params.hold:
                    self.done = True
                else:
                    self._finish()
                return events
        elif self.mode == "loop":
            if self.pos >= duration:
                self.pos %= duration
                wrapped = True
        else:  # ping_pong: bounce at both ends
            if self.pos >= duration:
                self.pos, self.direction = 2 * duration - self.pos, -1.0
            elif self.pos <= 0.0:
                self.pos, self.direction = -self.pos, 1.0
        if wrapped:
            return self._events_between(clip, before, duration) + self._events_between(clip, -1e-12, self.pos)
        if self.direction > 0:
            return self._events_between(clip, before, self.pos)
        return []

    @staticmethod
    def _events_between(clip: CompiledClip, t0: float, t1: float) -> list[FrameEvent]:
        """Events with t0 < t <= t1 (an event at 0 fires on the first tick)."""
        if t0 <= 0.0:
            t0 = -1e-12
        return [e for t, e in clip.events if t0 < t <= t1]
