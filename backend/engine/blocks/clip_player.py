"""The clip player: plays keyframed clips from the robot's library, live and steerable."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from backend.engine.blocks.base import (
    BlockCommandError,
    Port,
    PortType,
    Source,
)
from backend.engine.blocks.cells import cell, flag
from backend.engine.blocks.clip_params import MAX_QUEUE, ClipPlayerBusy, ClipPlayerParams
from backend.engine.blocks.quiet import TRIGGER_ONLY, QuietWhenIdle
from backend.engine.clips import ClipError, CompiledClip, compile_clip, time_map
from backend.engine.compiled import entry_point
from backend.engine.compiled.curves import CLIP_SIG, clip_tick
from backend.engine.frames import FrameEvent, PartialFrame, SteadyFrame
from backend.engine.selectors import channel_mask


def smooth_step(x: float) -> float:
    """The envelope's and the crossfade's ease: smoothstep of x clamped to [0, 1]."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


class ClipPlayer(QuietWhenIdle, Source[ClipPlayerParams]):
    """Plays keyframed clips (per-DoF animation curves) once, looped or ping-pong, at any speed.

    Commands: `play {clip, speed?, mode?, crossfade?, anchors?, if_busy?}`, `stop {fade?, command_id?}`,
    `seek {t}`. A new clip crossfades from the pose the player shows now; `anchors` warp the clip's named
    marks to given times after the start (a beat meets a word). Clip events (speech, sounds) fire as the
    playhead passes them. Reports started, completed and cancelled with the command's id.

    While a clip plays, `if_busy` says what a new play does: `replace` (default) cancels it and every
    queued play and crossfades to the new clip; `queue` waits until the clip completes (or is
    cancelled) and reports `started` only then (at most MAX_QUEUE wait); `reject` refuses
    (ClipPlayerBusy). `stop` with a `command_id` cancels that play only (playing or queued; the next
    queued play starts); without one it cancels the clip and the whole queue. The `weight` output is the blend
    envelope (0..1): wire it to the layer mixer's `<layer>_weight` port so the gesture layer fades in over
    `crossfade` and out over `release`; a `relative` clip also fades its offsets itself.
    """

    type_name = "clip_player"
    title = "Clip player"
    inputs = {"trigger": Port(PortType.bool, "a rising edge plays `clip`")}
    outputs = {
        "out": Port(PortType.frame, "the clip's pose on its DoFs"),
        "weight": Port(PortType.float, "blend envelope 0..1 (wire to the mixer's layer weight)"),
        "playing": Port(PortType.bool, "true while a clip plays"),
        "time": Port(PortType.float, "clip time (s)"),
    }

    @dataclass
    class State:
        values: np.ndarray  # the pose shown (before the relative-clip fade)
        from_values: np.ndarray  # the pose a crossfade starts from
        mask: np.ndarray  # the DoFs of the current clip
        old_mask: np.ndarray  # the DoFs of the clip being crossfaded out
        mode: str  # once | loop | ping_pong
        pending_autoplay: bool  # start `clip` on the first tick
        current: CompiledClip | None = None
        command_id: Any = None
        last_trigger: bool = False
        warp: tuple[np.ndarray, np.ndarray] | None = None  # anchor time map (play time -> clip time)
        speed: float | None = None  # the play command's speed (None: the parameter)
        queue: list[dict[str, Any]] = field(default_factory=list)  # plays waiting (args, command_id)
        # The playhead, envelope and crossfade as cells of one array (CLOCK): the compiled core steps them
        # in place while a clip plays (backend/engine/core/clip_ops.py).
        clock: np.ndarray = field(
            default_factory=lambda: np.array([0, 0, 1, 0, 0, 0, 0, 0, 0, 0], dtype=float)
        )

        pos = cell("clock", 0, "Clip time (s).")
        play_t = cell("clock", 1, "Time since play (s).")
        direction = cell("clock", 2, "+1 forward, -1 backward (ping_pong).")
        env = cell("clock", 3, "The blend envelope, 0..1.")
        env_target = cell("clock", 4, "What the envelope moves to, 0 or 1.")
        xfade_t = cell("clock", 5, "Seconds into the crossfade.")
        xfade = cell("clock", 6, "The crossfade's length (s).")
        fade_in = cell("clock", 7, "The envelope's fade-in time (s).")
        fade_out = cell("clock", 8, "The envelope's fade-out time (s).")
        done = flag("clock", 9, "The clip ended or was stopped (fading out).")

    def configure(self) -> None:
        self.allowed = channel_mask(self.emb, self.params.dofs)
        self._cache: dict[str, tuple[int, CompiledClip]] = {}
        self._kernel = entry_point(clip_tick, CLIP_SIG) if self.ctx.compiled else None
        self._no_mask = np.zeros(
            self.emb.n_channels, dtype=bool
        )  # shared by every frame out of sight: read-only
        if self.params.clip and self.ctx.resources is not None:
            self._load(self.params.clip)  # an unknown or broken clip is a configuration error, named

    def reset(self) -> None:
        n, p = self.emb.n_channels, self.params
        state = self.State(
            values=self.emb.rest.copy(),
            from_values=self.emb.rest.copy(),
            mask=np.zeros(n, dtype=bool),
            old_mask=np.zeros(n, dtype=bool),
            mode=p.mode,
            pending_autoplay=bool(p.autoplay and p.clip),
        )
        state.fade_in, state.fade_out = p.crossfade, p.release
        self.state = state

    # --- clips --------------------------------------------------------------------------------------
    def _load(self, name: str, document: Any = None) -> CompiledClip:
        """The library's clip `name`, or `document` (an unsaved clip: the clip editor's working copy)."""
        doc = document
        if document is None:
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
        elif not isinstance(document, dict):
            raise BlockCommandError("document must be a nutty-clip/1 object")
        try:
            compiled = compile_clip(doc if document is None else {**doc, "name": name}, self.emb)
        except ClipError as exc:
            raise BlockCommandError(f"clip '{name}': {exc}") from exc
        compiled.mask &= self.allowed
        if document is None:
            self._cache[name] = (id(doc), compiled)
        return compiled

    def _prepare(self, name: str, args: dict[str, Any]) -> tuple[CompiledClip, str, Any, Any, float]:
        """The clip and how to play it (clip, mode, speed, anchor warp, crossfade), or BlockCommandError."""
        clip = self._load(name, args.get("document"))
        mode = str(args.get("mode") or self.params.mode)
        if mode not in ("once", "loop", "ping_pong"):
            raise BlockCommandError(f"mode must be once, loop or ping_pong, got '{mode}'")
        speed = args.get("speed")
        if speed is not None and not (isinstance(speed, (int, float)) and 0.05 <= speed <= 5.0):
            raise BlockCommandError(f"speed must be within [0.05, 5], got {speed!r}")
        warp = None
        if args.get("anchors"):
            try:
                warp = time_map(
                    clip.duration, float(speed or self.params.speed), clip.anchors, dict(args["anchors"])
                )
            except ClipError as exc:
                raise BlockCommandError(f"clip '{name}': {exc}") from exc
        crossfade = args.get("crossfade")
        crossfade = self.params.crossfade if crossfade is None else float(crossfade)
        return clip, mode, speed, warp, crossfade

    def _start(self, name: str, args: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        clip, mode, speed, warp, crossfade = self._prepare(name, args)
        if s.current is not None and not s.done:
            self.ctx.notify(self.node_id, "cancelled", command_id=s.command_id, clip=s.current.name)
        # A clip replacing a visible one crossfades from the shown pose; from nothing, the envelope fades in.
        s.from_values = s.values.copy()
        s.old_mask = s.mask & (s.env > 0.0)
        s.xfade = crossfade if s.env > 0.0 else 0.0
        s.xfade_t = 0.0
        s.current, s.mode, s.speed, s.warp = clip, mode, speed, warp
        start = min(max(float(args.get("start") or 0.0), 0.0), clip.duration)
        s.pos, s.play_t, s.direction, s.done = start, 0.0, 1.0, False
        s.env_target = 1.0
        s.fade_in = crossfade
        s.mask = clip.mask.copy()
        s.command_id = args.get("command_id")
        self.ctx.notify(self.node_id, "started", command_id=s.command_id, clip=name, duration=clip.duration)
        return {"clip": name, "duration": clip.duration, "mode": mode}

    def busy(self) -> bool:
        """Whether a clip plays now (not yet completed, stopped or fading out)."""
        return self.state.current is not None and not self.state.done

    def playing(self) -> dict[str, Any] | None:
        """What plays now, for status reports: {clip, command_id, t (s), duration (s), progress (0..1),
        mode, queued: [{clip, command_id}]}; None when nothing plays or waits."""
        s = self.state
        queued = [{"clip": q["clip"], "command_id": q.get("command_id")} for q in s.queue]
        if not self.busy():
            return {"clip": None, "command_id": None, "queued": queued} if queued else None
        clip = s.current
        return {
            "clip": clip.name,
            "command_id": s.command_id,
            "t": round(s.pos, 3),
            "duration": clip.duration,
            "progress": round(min(max(s.pos / clip.duration, 0.0), 1.0), 3) if clip.duration > 0 else 1.0,
            "mode": s.mode,
            "queued": queued,
        }

    def _play(self, args: dict[str, Any]) -> dict[str, Any]:
        name = args.get("clip") or self.params.clip
        if not name:
            raise BlockCommandError(f"clip player '{self.node_id}' has no clip to play: give 'clip'")
        policy = args.get("if_busy") or "replace"
        if policy not in ("replace", "queue", "reject"):
            raise BlockCommandError(f"if_busy must be replace, queue or reject, got {policy!r}")
        s = self.state
        if self.busy() and policy == "reject":
            raise ClipPlayerBusy(self.node_id, s.current.name, s.command_id)
        if self.busy() and policy == "queue":
            if len(s.queue) >= MAX_QUEUE:
                raise BlockCommandError(f"clip player '{self.node_id}' already has {MAX_QUEUE} plays queued")
            self._prepare(str(name), args)  # an unknown clip or bad argument is refused now, not on its turn
            s.queue.append({**args, "clip": str(name)})
            return {"clip": str(name), "queued": True, "position": len(s.queue)}
        self._cancel_queue()
        return self._start(str(name), args)

    def _cancel_queue(self, command_id: Any = None) -> bool:
        """Drop queued plays (all, or the one of `command_id`), each reported cancelled."""
        s = self.state
        dropped = [q for q in s.queue if command_id is None or q.get("command_id") == command_id]
        s.queue = [q for q in s.queue if q not in dropped]
        for q in dropped:
            self.ctx.notify(self.node_id, "cancelled", command_id=q.get("command_id"), clip=q["clip"])
        return bool(dropped)

    def _next_queued(self) -> None:
        """Start the first queued play; one that can no longer start (its clip was deleted) is reported
        as an error and cancelled, and the next is tried."""
        s = self.state
        while s.queue:
            args = s.queue.pop(0)
            try:
                self._start(args["clip"], args)
                return
            except BlockCommandError as exc:
                self.ctx.notify(
                    self.node_id,
                    "cancelled",
                    command_id=args.get("command_id"),
                    clip=args["clip"],
                    message=str(exc),
                )

    def _stop(self, args: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        command_id = args.get("command_id")
        if command_id is not None and (not self.busy() or s.command_id != command_id):
            return {"stopped": self._cancel_queue(command_id)}  # a queued play, or nothing of this command
        if command_id is None:
            self._cancel_queue()
        if not self.busy():
            return {"stopped": False}
        self.ctx.notify(self.node_id, "cancelled", command_id=s.command_id, clip=s.current.name)
        self._finish(args.get("fade"))
        self._next_queued()
        return {"stopped": True}

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        s = self.state
        if command == "play":
            return self._play(args)
        if command == "stop":
            return self._stop(args)
        if command == "seek":
            if s.current is None:
                raise BlockCommandError(f"clip player '{self.node_id}' is not playing a clip")
            t = float(args.get("t", 0.0))
            if not 0.0 <= t <= s.current.duration:
                raise BlockCommandError(f"seek time {t} s is outside the clip (0..{s.current.duration} s)")
            s.pos, s.warp = t, None  # a seek leaves any anchor warp behind
            return {"t": t}
        return super().handle(command, args)

    def _finish(self, fade: float | None = None) -> None:
        s = self.state
        s.done = True
        s.env_target = 0.0
        s.fade_out = self.params.release if fade is None else float(fade)

    # --- tick ---------------------------------------------------------------------------------------
    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s, self.quiet = self.state, False
        trigger = bool(inputs.get("trigger") or False)
        name = self.params.clip
        if s.pending_autoplay or (trigger and not s.last_trigger and name):
            s.pending_autoplay = False
            if name:  # autoplay is only pending with a clip set
                try:
                    self._start(name, {})
                except BlockCommandError as exc:
                    self.ctx.notify(self.node_id, "error", message=str(exc))
        s.last_trigger = trigger
        clip = s.current
        events: list[FrameEvent] = []
        if clip is not None:
            self._idle = None  # the values may change in place from here on
            if not s.done:
                # the wired speed, else the play command's, else the parameter
                speed = self.driven(inputs, speed=s.speed or self.params.speed).speed
                events = self._advance(clip, dt, speed)
                clip = s.current  # a queued clip may have started as this one completed
            if self._kernel is not None and self.ctx.compiled and s.values.shape == self.emb.rest.shape:
                return self._tick_compiled(self._kernel, dt, clip, events)
            clip.sample(s.pos, self.emb.rest, s.values)
            if s.xfade_t < s.xfade:
                s.xfade_t += dt
                k = smooth_step(s.xfade_t / s.xfade)
                s.values = np.where(
                    s.old_mask & ~s.mask, s.from_values, s.from_values + k * (s.values - s.from_values)
                )
            self._advance_envelope(dt)
            if s.done and s.env <= 0.0:
                s.current = None
        weight = smooth_step(s.env)
        visible = s.current is not None or s.env > 0.0
        if visible:
            mask = s.mask | (s.old_mask if s.xfade_t < s.xfade else False)
        else:  # nothing shows: the block's one empty mask (never changed)
            mask = self._no_mask if s.mask.shape == self._no_mask.shape else np.zeros_like(s.mask)
        values = s.values
        if clip is None and not visible and not events:  # idle (most ticks): one frame until a clip plays
            self.quiet, self.quiet_reads = True, TRIGGER_ONLY  # until a command, the trigger, new parameters
            idle = self.__dict__.get("_idle")
            if idle is None or idle[0] is not s or idle[1] is not values or idle[2].mask is not mask:
                idle = self._idle = (s, values, SteadyFrame(values.copy(), mask, []))
            return {"out": idle[2], "weight": weight, "playing": False, "time": s.pos}
        if clip is not None and clip.relative.any():
            rest = self.emb.rest
            values = rest + weight * (values - rest)
        return {
            "out": PartialFrame(values.copy(), mask, events),
            "weight": weight,
            "playing": s.current is not None and not s.done,
            "time": s.pos,
        }

    def _tick_compiled(
        self, kernel: Callable[..., None], dt: float, clip: CompiledClip, events: list[FrameEvent]
    ) -> dict[str, Any]:
        """The compiled twin of the end of `tick` with a clip: sample, crossfade, envelope, frame out.
        The mask out is the state's own (never changed in place) unless a crossfade adds the old one."""
        s, rest = self.state, self.emb.rest
        xfade = s.xfade_t < s.xfade
        k = 0.0
        if xfade:
            s.xfade_t += dt
            k = smooth_step(s.xfade_t / s.xfade)
        self._advance_envelope(dt)
        if s.done and s.env <= 0.0:
            s.current = None
        weight = smooth_step(s.env)
        out = np.empty(rest.shape[0])
        c = clip.curves
        kernel(
            c.t,
            c.v,
            c.h_right,
            c.h_left,
            c.code,
            c.mode,
            c.n_keys,
            float(s.pos),
            clip.channels,
            clip.relative,
            clip.enum_curves,
            rest,
            s.values,
            xfade,
            k,
            s.from_values,
            s.old_mask,
            s.mask,
            clip.any_relative,
            weight,
            out,
        )
        if s.current is None and s.env <= 0.0:
            mask = self._no_mask
        elif s.xfade_t < s.xfade:  # both clips' channels: worked out once per crossfade (masks never change)
            memo = self.__dict__.get("_xfade_mask")
            if memo is None or memo[0] is not s.mask or memo[1] is not s.old_mask:
                memo = self._xfade_mask = (s.mask, s.old_mask, s.mask | s.old_mask)
            mask = memo[2]
        else:
            mask = s.mask
        return {
            "out": PartialFrame(out, mask, events),
            "weight": weight,
            "playing": s.current is not None and not s.done,
            "time": s.pos,
        }

    def _advance_envelope(self, dt: float) -> None:
        s = self.state
        if s.env < s.env_target:
            rate = 1.0 / s.fade_in if s.fade_in > 0 else math.inf
            s.env = min(s.env_target, s.env + rate * dt)
        elif s.env > s.env_target:
            rate = 1.0 / s.fade_out if s.fade_out > 0 else math.inf
            s.env = max(s.env_target, s.env - rate * dt)

    def _advance(self, clip: CompiledClip, dt: float, speed: float) -> list[FrameEvent]:
        s = self.state
        before = s.pos
        duration = clip.duration
        s.play_t += dt
        wrapped = False
        if s.warp is not None and s.mode == "once":
            s.pos = float(np.interp(s.play_t, *s.warp))
        else:
            s.pos += s.direction * speed * dt
        if s.mode == "once":
            if s.pos >= duration:
                s.pos = duration
                events = self._events_between(clip, before, duration)
                self.ctx.notify(
                    self.node_id,
                    "completed",
                    command_id=s.command_id,
                    clip=clip.name,
                    _channels=tuple(np.flatnonzero(clip.mask).tolist()),  # what the clip moved (action watch)
                )
                if self.params.hold:
                    s.done = True
                else:
                    self._finish()
                self._next_queued()
                return events
        elif s.mode == "loop":
            if s.pos >= duration:
                s.pos %= duration
                wrapped = True
        else:  # ping_pong: bounce at both ends
            if s.pos >= duration:
                s.pos, s.direction = 2 * duration - s.pos, -1.0
            elif s.pos <= 0.0:
                s.pos, s.direction = -s.pos, 1.0
        if wrapped:
            return self._events_between(clip, before, duration) + self._events_between(clip, -1e-12, s.pos)
        if s.direction > 0:
            return self._events_between(clip, before, s.pos)
        return []

    @staticmethod
    def _events_between(clip: CompiledClip, t0: float, t1: float) -> list[FrameEvent]:
        """Events with t0 < t <= t1 (an event at 0 fires on the first tick)."""
        if not clip.events:
            return []
        if t0 <= 0.0:
            t0 = -1e-12
        return [e for t, e in clip.events if t0 < t <= t1]
