"""Sources for the display and audible dimensions: LEDs, face expressions, speech and sounds.

The LED and face blocks set display DoFs (a colour, an enum option); the say and play-sound blocks put
events on the frame (the driver speaks or plays them) and report `started` / `completed` to the engine,
so an AI can wait for an utterance to end. While speaking, the say block flaps the mouth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator

from backend.engine.blocks.base import (
    FRAME_OUT,
    BlockCommandError,
    BlockParams,
    Port,
    PortType,
    Source,
    colour_or_none,
    drivable,
    soft_range,
)
from backend.engine.embodiment import Dimension, Dof, DofType, Embodiment
from backend.engine.frames import FrameEvent, PartialFrame


def _resolve_dof(emb: Embodiment, name: str | None, want: DofType, what: str, kind: str | None = None) -> Dof:
    """The named DoF (checked to be of type `want`, and audible `kind`), or the robot's first such DoF."""

    def fits(d: Dof) -> bool:
        return d.type is want and (kind is None or d.kind == kind)

    label = f"{kind} " if kind else f"{want.value} "
    if name:
        if not emb.has_dof(name):
            raise ValueError(f"{what}: robot '{emb.name}' has no DoF '{name}'")
        d = emb.dof(name)
        if not fits(d):
            raise ValueError(f"{what}: DoF '{name}' is not a {label}DoF")
        return d
    found = next(
        (d for d in emb.dofs if fits(d) and (want is not DofType.enum or d.dimension is Dimension.display)),
        None,
    )
    if found is None:
        raise ValueError(f"{what}: robot '{emb.name}' has no {label}DoF")
    return found


def _colour(value: Any, where: str) -> np.ndarray:
    """A colour [r, g, b] with components in [0, 1]; raises BlockCommandError naming `where`."""
    c = colour_or_none(value)
    if c is None:
        raise BlockCommandError(f"{where}: a colour is [r, g, b] with components in 0..1, got {value!r}")
    return c


# --------------------------------------------------------------------------------------------------
# LED
# --------------------------------------------------------------------------------------------------


class LedParams(BlockParams):
    dof: str | None = Field(
        default=None,
        description="colour DoF (LED or LED group); default: the robot's first",
        json_schema_extra={"x-widget": "dof"},
    )
    colour: list[float] = drivable(
        Field(
            default=[1.0, 1.0, 1.0],
            min_length=3,
            max_length=3,
            description="colour [r, g, b], components 0..1",
            json_schema_extra={"x-widget": "colour"},
        ),
        "overrides the colour [r, g, b]",
        port=PortType.colour,
    )
    mode: Literal["solid", "pulse", "breathe"] = Field(
        default="solid",
        description="solid; pulse (a quick flash then a fade, like a heartbeat); breathe (a slow sine)",
    )
    frequency: float = drivable(
        Field(default=0.5, ge=0.0, le=10.0, description="pulses or breaths per second (Hz)"),
        "overrides the frequency (Hz)",
        clamp="floor",
    )
    depth: float = drivable(
        Field(
            default=0.5, ge=0.0, le=1.0, description="how far the brightness dips (0 = none, 1 = to black)"
        ),
        "overrides the depth (0..1)",
        clamp="range",
    )

    @field_validator("colour")
    @classmethod
    def _range(cls, v: list[float]) -> list[float]:
        if not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in v):
            raise ValueError(f"colour components must be within 0..1, got {v}")
        return v


def brightness(mode: str, u: float, depth: float) -> float:
    """Brightness factor in [1 - depth, 1] at phase u in [0, 1) (cycles)."""
    if mode == "breathe":
        return 1.0 - depth * (0.5 - 0.5 * math.cos(2.0 * math.pi * u))
    if mode == "pulse":
        attack = 0.12
        level = 0.5 - 0.5 * math.cos(math.pi * u / attack) if u < attack else math.exp(-5.0 * (u - attack))
        return (1.0 - depth) + depth * level
    return 1.0


class Led(Source[LedParams]):
    """Sets an LED (a colour DoF) to a colour, solid, pulsing or breathing.

    The colour comes from the `colour` input when connected, else from the last `set_led` command, else
    from the parameter. Pulse and breathe modulate the brightness by `depth` at `frequency` Hz; every
    component stays within 0..1.
    """

    type_name = "led"
    title = "LED"

    @dataclass
    class State:
        cycles: float = 0.0  # pulse/breath phase (cycles)
        commanded: np.ndarray | None = None  # the colour of the last set_led command

    def configure(self) -> None:
        self.dof = _resolve_dof(self.emb, self.params.dof, DofType.colour, "led")
        self.mask = np.zeros(self.emb.n_channels, dtype=bool)
        self.mask[self.dof.channels] = True

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "set_led":
            dof = args.get("dof")
            if dof and dof != self.dof.name:
                raise BlockCommandError(f"led '{self.node_id}' drives '{self.dof.name}', not '{dof}'")
            self.state.commanded = _colour(args.get("colour"), "set_led")
            return {"dof": self.dof.name, "colour": [float(c) for c in self.state.commanded]}
        return super().handle(command, args)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        # A wired colour wins; a malformed one falls back to the last command, else the parameter.
        fallback = s.commanded if s.commanded is not None else self.params.colour
        if "colour" in inputs:
            d = self.driven(inputs, colour=fallback)
            colour = d.colour
        else:  # unwired, the colour is the fallback's, converted once per command or parameter change
            d = self.driven(inputs)
            seen = self.__dict__.get("_fallback")
            if seen is None or seen[0] is not fallback:
                seen = self._fallback = (fallback, self.drivables["colour"].resolve(None, fallback))
            colour = seen[1]
        factor = brightness(self.params.mode, s.cycles % 1.0, d.depth)
        s.cycles = (s.cycles + d.frequency * dt) % 1.0
        values = self.emb.rest.copy()
        # np.clip(colour * factor, 0, 1) on three numbers, without numpy's per-call cost
        rgb = (
            colour.tolist()
            if type(colour) is np.ndarray and colour.ndim == 1
            else np.asarray(colour, dtype=float).ravel().tolist()
        )
        # (min(max(v, 0), 1) as comparisons: the same result, NaN and -0.0 included, without two calls each)
        values[self.dof.channels] = [
            0.0 if v < 0.0 else 1.0 if v > 1.0 else v for v in [c * factor for c in rgb]
        ]
        return {"out": PartialFrame(values, self.mask, [])}


# --------------------------------------------------------------------------------------------------
# Face
# --------------------------------------------------------------------------------------------------


class FaceParams(BlockParams):
    dof: str | None = Field(
        default=None,
        description="enum display DoF (face/screen); default: the robot's first",
        json_schema_extra={"x-widget": "dof"},
    )
    expression: str | None = drivable(
        Field(default=None, description="option to show; default: the DoF's rest option"),
        "overrides the expression (an option name)",
        port=PortType.string,
    )


class Face(Source[FaceParams]):
    """Shows a face/screen expression: one option of an enum display DoF (smile, frown, …).

    The expression comes from the `expression` input when connected (unknown names are ignored), else
    from the last `set_face` command, else from the parameter. Unknown expressions in the parameter or
    a command are errors that list the DoF's options.
    """

    type_name = "face"
    title = "Face expression"

    @dataclass
    class State:
        commanded: int | None = None  # the option index of the last set_face command

    def configure(self) -> None:
        self.dof = _resolve_dof(self.emb, self.params.dof, DofType.enum, "face")
        self.options = list(self.dof.options or ())
        self.channel = self.dof.channels.start
        self.mask = np.zeros(self.emb.n_channels, dtype=bool)
        self.mask[self.channel] = True
        if self.params.expression is None:
            self.default_index = round(float(self.emb.rest[self.channel]))
        else:
            self.default_index = self._index(self.params.expression, ValueError)

    def _index(self, name: Any, error: type[Exception]) -> int:
        if not isinstance(name, str) or name not in self.options:
            raise error(f"face: DoF '{self.dof.name}' has no expression {name!r} (options: {self.options})")
        return self.options.index(name)

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "set_face":
            dof = args.get("dof")
            if dof and dof != self.dof.name:
                raise BlockCommandError(f"face '{self.node_id}' drives '{self.dof.name}', not '{dof}'")
            self.state.commanded = self._index(args.get("expression"), BlockCommandError)
            return {"dof": self.dof.name, "expression": self.options[self.state.commanded]}
        return super().handle(command, args)

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        commanded = self.state.commanded
        index = commanded if commanded is not None else self.default_index
        # unknown names are ignored; unconnected, the expression resolves to None
        wired = self.driven(inputs, expression=None).expression if "expression" in inputs else None
        if isinstance(wired, str) and wired in self.options:
            index = self.options.index(wired)
        values = self.emb.rest.copy()
        values[self.channel] = index
        return {"out": PartialFrame(values, self.mask, [])}


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


class Say(Source[SayParams]):
    """Speaks a text: a `say` event on the speech DoF, with the mouth flapping while it lasts.

    Triggered by the `say` command (the API's say, which waits for completion) or a rising edge of the
    `trigger` input (saying `text`). It reports `started` when the event is emitted and `completed`
    after the estimated duration (words / words_per_second); a new utterance cancels the running one.
    While speaking, the lip DoF (mouth_open by default) opens and closes at the syllable rate.
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
        self.dof = _resolve_dof(emb, self.params.dof, DofType.event, "say", kind="speech")
        self.lip: int | None = None
        name = self.params.lip_dof
        if self.params.lip_sync:
            if name:
                self.lip = _resolve_dof(emb, name, DofType.continuous, "say lip_dof").channels.start
            elif emb.has_dof("mouth_open") and emb.dof("mouth_open").type is DofType.continuous:
                self.lip = emb.dof("mouth_open").channels.start
        self.lip_mask = np.zeros(emb.n_channels, dtype=bool)
        if self.lip is not None:
            self.lip_mask[self.lip] = True
        self._nothing = np.zeros(emb.n_channels, dtype=bool)  # the mask while silent (shared, read-only)

    def duration(self, text: str) -> float:
        return max(self.params.min_duration, len(text.split()) / self.params.words_per_second)

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "say":
            text = str(args.get("text") or "").strip()
            if not text:
                raise BlockCommandError("say: the text is empty")
            self.state.pending = {"text": text, "command_id": args.get("command_id")}
            return {"text": text, "duration": self.duration(text)}
        if command in ("stop", "cancel"):
            self._cancel()
            self.state.pending = None
            return {"stopped": True}
        return super().handle(command, args)

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
            s.elapsed, s.length = 0.0, self.duration(s.current["text"])
            events.append(FrameEvent(self.dof.name, "say", {"text": s.current["text"]}))
            self.ctx.notify(
                self.node_id, "started", command_id=s.current["command_id"], text=s.current["text"]
            )
        values = self.emb.rest.copy()
        mask = self._nothing  # the masks out are the block's own two, never changed: nothing, or the lip DoF
        if s.current is not None:
            if self.lip is not None:
                span = self.emb.max[self.lip] - self.emb.rest[self.lip]
                flap = 0.5 - 0.5 * math.cos(2.0 * math.pi * self.params.syllable_rate * s.elapsed)
                values[self.lip] = self.emb.rest[self.lip] + self.params.lip_amount * span * flap
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
        description="estimated length of a clip, for `completed` (s)",
        json_schema_extra=soft_range(0.05, 10, 0.05),
    )


class PlaySound(Source[PlaySoundParams]):
    """Plays a sound clip: a `sound` event on the sound DoF, with started/completed notifications.

    Triggered by the `play_sound` command or a rising edge of the `trigger` input (playing `sound`).
    Clip names are checked against the sound DoF's list; `completed` follows after `duration` seconds.
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
        self.dof = _resolve_dof(self.emb, self.params.dof, DofType.event, "play_sound", kind="sound")
        self.sounds = list(self.dof.sounds)
        if self.params.sound is not None:
            self._check(self.params.sound, ValueError)
        self.trigger_sound = self.params.sound or (self.sounds[0] if self.sounds else None)
        self._nothing = np.zeros(
            self.emb.n_channels, dtype=bool
        )  # the mask of every frame out (shared, read-only)

    def _check(self, name: Any, error: type[Exception]) -> str:
        if not isinstance(name, str) or not name or (self.sounds and name not in self.sounds):
            raise error(f"play_sound: unknown sound {name!r} on '{self.dof.name}' (options: {self.sounds})")
        return name

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "play_sound":
            name = self._check(args.get("sound"), BlockCommandError)
            self.state.pending.append({"sound": name, "command_id": args.get("command_id")})
            return {"sound": name, "duration": self.params.duration}
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
            s.active.append({**clip, "remaining": self.params.duration})
        s.pending = []
        return {"out": PartialFrame(self.emb.rest.copy(), self._nothing, events), "playing": bool(s.active)}
