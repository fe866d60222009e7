"""Sources for the audible dimension: speech and sounds.

The say and play-sound blocks put events on the frame (the driver speaks or plays them; a sound with a
file carries its URL, backend.session) and report `started` / `completed` to the engine, so an AI can
wait for an utterance to end. While speaking, the say block moves the mouth: a flap for a voice it
does not hear, the loudness of recorded speech for a recording.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import Field

from backend.engine.blocks.base import (
    FRAME_OUT,
    BlockCommandError,
    BlockParams,
    Port,
    PortType,
    Source,
    drivable,
    soft_range,
)
from backend.engine.blocks.display import resolve_dof
from backend.engine.blocks.quiet import QuietWhenIdle
from backend.engine.embodiment import DofType
from backend.engine.frames import FrameEvent, PartialFrame, SteadyFrame

# --------------------------------------------------------------------------------------------------
# Say
# --------------------------------------------------------------------------------------------------


class SayParams(BlockParams):
    dof: str | None = Field(
        default=None,
        description="speech DoF; default: the robot's first",
        json_schema_extra={"x-widget": "dof"},
    )
    text: str = drivable(
        Field(default="", max_length=2000, description="text said on a rising edge of the trigger input"),
        "overrides the text parameter",
        port=PortType.string,
    )
    words_per_second: float = Field(
        default=2.5, ge=0.5, le=10.0, description="speaking rate used to estimate the duration"
    )
    min_duration: float = Field(default=0.4, ge=0.0, le=10.0, description="shortest estimated utterance (s)")
    lip_sync: bool = Field(default=True, description="flap the mouth while speaking")
    lip_dof: str | None = Field(
        default=None,
        description="continuous DoF opening the mouth; default: mouth_open if any",
        json_schema_extra={"x-widget": "dof"},
    )
    syllable_rate: float = Field(default=4.0, ge=0.5, le=12.0, description="mouth flaps per second (Hz)")
    lip_amount: float = Field(
        default=0.7, ge=0.0, le=1.0, description="how far the mouth opens (fraction of its range)"
    )
    jaw_dof: str | None = Field(
        default=None,
        description="continuous DoF (a jaw joint) that opens with the mouth; default: a DoF named jaw, if any",
        json_schema_extra={"x-widget": "dof"},
    )


class Say(QuietWhenIdle, Source[SayParams]):
    """Speaks a text: a `say` event on the speech DoF, with the mouth moving while it lasts.

    Triggered by the `say` command (the API's say, which waits for completion) or a rising edge of the
    `trigger` input (saying `text`). It reports `started` when the event is emitted and `completed`
    after the utterance's length; a new utterance cancels the running one. A text alone is spoken by
    the robot's voice: its length is estimated (words / words_per_second) and the lip DoF (mouth_open
    by default) flaps at the syllable rate. With `audio` (one of the robot's sounds: recorded speech)
    the event carries the recording, the length is the recording's, and the lip and jaw DoFs follow its
    loudness envelope (smoothed RMS per tick, computed once per sound; backend.engine.sounds).
    """

    type_name = "say"
    title = "Say"
    inputs = {"trigger": Port(PortType.bool, "says `text` on a rising edge")}
    outputs = {**FRAME_OUT, "speaking": Port(PortType.bool, "true while speaking")}

    @dataclass
    class State:
        pending: dict[str, Any] | None = None  # the utterance to start next tick {text, command_id}
        current: dict[str, Any] | None = None  # the utterance being said
        elapsed: float = 0.0  # s into it
        length: float = 0.0  # its estimated duration (s)
        last_trigger: bool = False
        closing: bool = False  # the mouth still has to close

    def configure(self) -> None:
        emb = self.emb
        self.dof = resolve_dof(emb, self.params.dof, DofType.event, "say", kind="speech")
        self.lip: int | None = None
        name = self.params.lip_dof
        if self.params.lip_sync:
            if name:
                self.lip = resolve_dof(emb, name, DofType.continuous, "say lip_dof").channels.start
            elif emb.has_dof("mouth_open") and emb.dof("mouth_open").type is DofType.continuous:
                self.lip = emb.dof("mouth_open").channels.start
        jaw = self.params.jaw_dof
        if jaw:
            self.jaw: int | None = resolve_dof(emb, jaw, DofType.continuous, "say jaw_dof").channels.start
        elif self.params.lip_sync and emb.has_dof("jaw") and emb.dof("jaw").type is DofType.continuous:
            self.jaw = emb.dof("jaw").channels.start
        else:
            self.jaw = None
        # the channels the mouth moves (lip, jaw), and how far each opens at full loudness
        self.mouth = np.array([c for c in (self.lip, self.jaw) if c is not None], dtype=np.intp)
        self.mouth_span = self.params.lip_amount * (emb.max[self.mouth] - emb.rest[self.mouth])
        self.lip_mask = np.zeros(emb.n_channels, dtype=bool)
        self.lip_mask[self.mouth] = True
        self._nothing = np.zeros(emb.n_channels, dtype=bool)  # the mask while silent (shared, read-only)
        self._silent = SteadyFrame(emb.rest.copy(), self._nothing, [])  # the frame out while silent

    def duration(self, text: str) -> float:
        return max(self.params.min_duration, len(text.split()) / self.params.words_per_second)

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "say":
            text = str(args.get("text") or "").strip()
            if not text:
                raise BlockCommandError("say: the text is empty")
            utterance = {"text": text, "command_id": args.get("command_id")}
            if args.get("audio"):
                utterance.update(self._recording(str(args["audio"])))
            self.state.pending = utterance
            return {"text": text, "duration": utterance.get("length", self.duration(text))}
        if command in ("stop", "cancel"):
            self._cancel()
            self.state.pending = None
            return {"stopped": True}
        return super().handle(command, args)

    def _recording(self, name: str) -> dict[str, Any]:
        """The recorded speech `name`: its length (s) and loudness per tick, or BlockCommandError."""
        sounds = getattr(self.ctx.resources, "sounds", None)
        info = sounds.find(name) if sounds is not None else None
        if sounds is None or info is None:
            known = sounds.list() if sounds is not None else []
            raise BlockCommandError(f"say: no sound '{name}' to speak from (sounds: {known})")
        return {"audio": name, "length": info.duration, "envelope": sounds.envelope(name, self.ctx.rate)}

    def _cancel(self) -> None:
        s = self.state
        if s.current is not None:
            self.ctx.notify(
                self.node_id, "cancelled", command_id=s.current["command_id"], text=s.current["text"]
            )
            s.current = None
            s.closing = True

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        trigger = bool(inputs.get("trigger") or False)
        self.quiet = False
        if trigger and not s.last_trigger:
            text = str(self.driven(inputs).text or "").strip()
            if text:
                s.pending = {"text": text, "command_id": None}
        s.last_trigger = trigger
        if s.current is not None:  # time goes on for the running utterance
            s.elapsed += dt
            if s.elapsed >= s.length - 1e-9:
                self.ctx.notify(
                    self.node_id, "completed", command_id=s.current["command_id"], text=s.current["text"]
                )
                s.current = None
                s.closing = True
        events: list[FrameEvent] = []
        if s.pending is not None:
            self._cancel()
            s.current, s.pending = s.pending, None
            s.elapsed, s.length = 0.0, s.current.get("length") or self.duration(s.current["text"])
            payload = {"text": s.current["text"]}
            extra = {"audio": s.current["audio"]} if "audio" in s.current else {}
            events.append(FrameEvent(self.dof.name, "say", {**payload, **extra}))
            self.ctx.notify(
                self.node_id, "started", command_id=s.current["command_id"], text=s.current["text"], **extra
            )
        if s.current is None and not s.closing:  # silent (most ticks): the block's one silent frame
            self.quiet = True  # nothing to say until a command or the trigger (quiet.py)
            return {"out": self._silent, "speaking": False}
        values = self.emb.rest.copy()
        mask = self._nothing  # the masks out are the block's own two, never changed: nothing, or the mouth
        if s.current is not None:
            if self.mouth.size:
                envelope = s.current.get("envelope")
                if envelope is not None:  # recorded speech: its loudness at this tick
                    k = min(int(s.elapsed * self.ctx.rate + 0.5), len(envelope) - 1)
                    opening = float(envelope[k])
                else:  # a voice we do not hear: a flap at the syllable rate
                    opening = 0.5 - 0.5 * math.cos(2.0 * math.pi * self.params.syllable_rate * s.elapsed)
                values[self.mouth] = self.emb.rest[self.mouth] + self.mouth_span * opening
                mask = self.lip_mask
        elif s.closing:  # one frame at rest closes the mouth; after that the lip DoF is left alone
            mask = self.lip_mask
            s.closing = False
        return {"out": PartialFrame(values, mask, events), "speaking": s.current is not None}


# --------------------------------------------------------------------------------------------------
# Play sound
# --------------------------------------------------------------------------------------------------


class PlaySoundParams(BlockParams):
    dof: str | None = Field(
        default=None,
        description="sound DoF; default: the robot's first",
        json_schema_extra={"x-widget": "dof"},
    )
    sound: str | None = Field(
        default=None, description="clip played on a rising edge of the trigger input; default: the first"
    )
    duration: float = Field(
        default=1.0,
        ge=0.05,
        le=60.0,
        description="length of a sound the robot plays by name, with no file (s; a file's own length wins)",
        json_schema_extra=soft_range(0.05, 10, 0.05),
    )


class PlaySound(QuietWhenIdle, Source[PlaySoundParams]):
    """Plays a sound clip: a `sound` event on the sound DoF, with started/completed notifications.

    Triggered by the `play_sound` command or a rising edge of the `trigger` input (playing `sound`).
    Names are checked against the sound DoF's list (the robot's sounds/ files, as they are now);
    `completed` follows after the file's length (`duration` for a sound the robot plays by name).
    Several clips may play at once.
    """

    type_name = "play_sound"
    title = "Play sound"
    inputs = {"trigger": Port(PortType.bool, "plays `sound` on a rising edge")}
    outputs = {**FRAME_OUT, "playing": Port(PortType.bool, "true while a clip plays")}

    @dataclass
    class State:
        pending: list[dict[str, Any]] = field(default_factory=list)  # clips to start next tick
        active: list[dict[str, Any]] = field(default_factory=list)  # clips playing, with their time left
        last_trigger: bool = False

    def configure(self) -> None:
        self.dof = resolve_dof(self.emb, self.params.dof, DofType.event, "play_sound", kind="sound")
        if self.params.sound is not None:
            self._check(self.params.sound, ValueError)
        self.trigger_sound = self.params.sound or (self.sounds[0] if self.sounds else None)
        self._nothing = np.zeros(
            self.emb.n_channels, dtype=bool
        )  # the mask of every frame out (shared, read-only)
        self._silent = SteadyFrame(self.emb.rest.copy(), self._nothing, [])  # the frame out with no event

    @property
    def sounds(self) -> list[str]:
        """The sound DoF's list as it is now (it follows the robot's sounds/ folder)."""
        return list(self.emb.dof(self.dof.name).sounds)

    def length(self, name: str) -> float:
        """s: the sound file's length, else the `duration` parameter (a sound the robot plays by name)."""
        sounds = getattr(self.ctx.resources, "sounds", None)
        info = sounds.find(name) if sounds is not None else None
        return info.duration if info is not None else self.params.duration

    def _check(self, name: Any, error: type[Exception]) -> str:
        if not isinstance(name, str) or not name or (self.sounds and name not in self.sounds):
            raise error(f"play_sound: unknown sound {name!r} on '{self.dof.name}' (options: {self.sounds})")
        return name

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "play_sound":
            name = self._check(args.get("sound"), BlockCommandError)
            self.state.pending.append({"sound": name, "command_id": args.get("command_id")})
            return {"sound": name, "duration": self.length(name)}
        if command in ("stop", "cancel"):
            for clip in self.state.active:
                self.ctx.notify(self.node_id, "cancelled", command_id=clip["command_id"], sound=clip["sound"])
            self.state.active, self.state.pending = [], []
            return {"stopped": True}
        return super().handle(command, args)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        trigger = bool(inputs.get("trigger") or False)
        if trigger and not s.last_trigger and self.trigger_sound:
            s.pending.append({"sound": self.trigger_sound, "command_id": None})
        s.last_trigger = trigger
        still = []
        for clip in s.active:
            clip["remaining"] -= dt
            if clip["remaining"] <= 1e-9:
                self.ctx.notify(self.node_id, "completed", command_id=clip["command_id"], sound=clip["sound"])
            else:
                still.append(clip)
        s.active = still
        events = []
        for clip in s.pending:
            events.append(FrameEvent(self.dof.name, "sound", {"clip": clip["sound"]}))
            self.ctx.notify(self.node_id, "started", command_id=clip["command_id"], sound=clip["sound"])
            s.active.append({**clip, "remaining": self.length(clip["sound"])})
        s.pending = []
        self.quiet = not events and not s.active  # nothing plays or counts down (quiet.py)
        if not events:  # (most ticks) the block's one silent frame
            return {"out": self._silent, "playing": bool(s.active)}
        return {"out": PartialFrame(self.emb.rest.copy(), self._nothing, events), "playing": bool(s.active)}
