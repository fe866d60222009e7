"""What the robot shows and says: LEDs, face expressions, speech and sounds.

Each goes to the program's own block for it when there is one (so the program stays in charge of
that DoF); otherwise the engine carries it out itself: a display override held on top of the
program, or an event injected into the next frame.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Literal

from pydantic import Field, field_validator

from backend.control.ai import AiTool
from backend.control.base import BaseCommand, BlockCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.control.postures import Vec3
from backend.control.session_view import CommandSession
from backend.control.targets import blocks_of, tell
from backend.engine.blocks.base import Block
from backend.engine.blocks.core import pose_vector
from backend.engine.embodiment import Dof, Embodiment
from backend.engine.frames import FrameEvent


class _Audible(BlockCommand):
    """Said or played by the program's block of that kind; without one, an event on the robot's
    channel of that kind, which needs no waiting (acked `completed`)."""

    long_action = True
    if TYPE_CHECKING:  # each subclass declares its Literal tag; Any, as a Literal narrows a str
        type: Any
    channel: ClassVar[str]  # the kind of event DoF that carries it without a block
    event: ClassVar[str]  # the FrameEvent kind it becomes

    def run(self, ctx: CommandContext) -> Any:
        session = ctx.session
        if blocks_of(session, self.acts_on.blocks):
            return self.tell(ctx, self.block(session), self.type, self.args())
        dof = next((d for d in session.embodiment.event_dofs if d.kind == self.channel), None)
        if dof is None:
            raise CommandError(
                f"robot '{session.embodiment.name}' has no {self.channel} channel", code="no_target"
            )
        self.check_channel(dof)

        payload = self.event_payload()
        session.engine.inject_event(FrameEvent(dof.name, self.event, payload))
        return {"dof": dof.name, **payload, "done": True}  # emitted at once: nothing left to wait for

    def check_channel(self, dof: Any) -> None:
        """Raise CommandError when the robot's channel cannot carry this command."""

    def event_payload(self) -> dict[str, Any]:
        raise NotImplementedError


class Say(_Audible):
    """Say a text: through the program's say block (lip flap, started/completed), else as a speech event."""

    acts_on = Target(blocks=("say",), role="engine", what="say block")
    ai_tool = AiTool(
        "say",
        "Say a sentence aloud (with the mouth moving while it speaks).",
        available=lambda live: live.has("say") or "speech" in live.channels,
        hide=("audio",),  # recordings are an animator's: AIs play them inside behaviours
        order=60,
    )
    channel = "speech"
    event = "say"
    type: Literal["say"] = "say"
    text: str = Field(..., min_length=1, max_length=2000, description="what to say")
    audio: str | None = Field(
        default=None,
        max_length=80,
        description="one of the robot's sounds: a recording of the text, played instead of the voice; "
        "the mouth follows its loudness",
    )

    def run(self, ctx: CommandContext) -> Any:
        if self.audio is not None and not ctx.session.library.sounds.has(self.audio):
            sounds = ctx.session.library.sounds.list()
            raise CommandError(f"no sound '{self.audio}' (sounds: {sounds})", field="audio")
        return super().run(ctx)

    def event_payload(self) -> dict[str, Any]:
        return {"text": self.text, **({"audio": self.audio} if self.audio else {})}

    @classmethod
    def stop_owned(cls, block: Block, command_id: str) -> None:
        s = block.state
        pending, current = s.pending, s.current
        if isinstance(pending, dict) and pending.get("command_id") == command_id:
            s.pending = None  # not started yet: drop it
        elif isinstance(current, dict) and current.get("command_id") == command_id:
            block.handle(
                "stop", {"command_id": command_id}
            )  # cancels the running one (and clears the queue) ...
            s.pending = pending  # ... so put back what another command queued


class PlaySound(_Audible):
    """Play a sound clip: through the program's play_sound block, else as a sound event."""

    acts_on = Target(blocks=("play_sound",), role="engine", what="play_sound block")
    ai_tool = AiTool(
        "play_sound",
        "Play one of the robot's sound effects.",
        available=lambda live: live.has("play_sound") or "sound" in live.channels,
        choices={"sound": (lambda live: live.sounds, "the robot's sounds")},
        order=70,
    )
    channel = "sound"
    event = "sound"
    type: Literal["play_sound"] = "play_sound"
    sound: str = Field(..., min_length=1, max_length=80, description="name of one of the robot's sounds")

    def run(self, ctx: CommandContext) -> Any:
        # the robot's list first, whoever plays it: a block's own refusal would not name the field
        players = [d for d in ctx.session.embodiment.event_dofs if d.kind == "sound"]
        if players and not any(not d.sounds or self.sound in d.sounds for d in players):
            self.check_channel(players[0])
        return super().run(ctx)

    def check_channel(self, dof: Any) -> None:
        if dof.sounds and self.sound not in dof.sounds:
            raise CommandError(f"unknown sound '{self.sound}' (one of {list(dof.sounds)})", field="sound")

    def event_payload(self) -> dict[str, Any]:
        return {"clip": self.sound}

    @classmethod
    def stop_owned(cls, block: Block, command_id: str) -> None:
        # A sound that started cannot be taken back; what is left is not to start it, or not to wait for it.
        s = block.state
        s.pending = [c for c in s.pending if c.get("command_id") != command_id]
        s.active = [c for c in s.active if c.get("command_id") != command_id]


class _Display(BaseCommand):
    """Shown by the program's block driving the DoF when there is exactly one; otherwise held as an
    engine override on the DoF (cleared by `reset` and `stop_all`). Subclasses declare the field
    `dof` (the DoF to set, None for the robot's first of `dof_type`) and the value's field."""

    if TYPE_CHECKING:  # each subclass declares these fields, with its own description and tag
        dof: str | None
        type: Any

    dof_type: ClassVar[str]  # the DofType (value) of the DoFs it can set
    value_field: ClassVar[str]  # the field holding the value, named in errors

    def run(self, ctx: CommandContext) -> Any:
        blocks = blocks_of(ctx.session, self.acts_on.blocks)
        if self.dof:
            blocks = [b for b in blocks if getattr(getattr(b, "dof", None), "name", None) == self.dof]
        if len(blocks) == 1:  # the program shows this DoF itself: tell its block
            args = self.model_dump(exclude={"type", "id"}, exclude_none=True)
            return tell(ctx.session, blocks[0], self.type, {**args, "command_id": ctx.command_id})
        return self.override(ctx.session)

    def value(self) -> Any:
        raise NotImplementedError

    def override(self, session: CommandSession) -> dict[str, Any]:

        dof = self.display_dof(session.embodiment)
        value = self.value()
        try:
            vec, mask = pose_vector(session.embodiment, {dof.name: value})
        except ValueError as exc:
            raise CommandError(str(exc), field=self.value_field) from exc
        session.engine.call(lambda: session.engine.set_override(mask, vec))
        return {"dof": dof.name, "value": value}

    def display_dof(self, emb: Embodiment) -> Dof:
        """The DoF named by `dof` (which must be of `dof_type`), else the robot's first of that type."""
        if not self.dof:
            dof = next((d for d in emb.dofs if d.type.value == self.dof_type), None)
            if dof is None:
                raise CommandError(f"robot '{emb.name}' has no {self.dof_type} display DoF", code="no_target")
            return dof
        if not emb.has_dof(self.dof):
            raise CommandError(f"robot '{emb.name}' has no DoF '{self.dof}'", field="dof")
        dof = emb.dof(self.dof)
        if dof.type.value != self.dof_type:
            raise CommandError(f"DoF '{dof.name}' is {dof.type.value}, not {self.dof_type}", field="dof")
        return dof


class SetLed(_Display):
    """Set a colour DoF (an LED or LED group) to an RGB colour in [0, 1]."""

    acts_on = Target(blocks=("led",), role="engine", what="led block")
    ai_tool = AiTool(
        "set_led",
        "Set an LED (or LED group) to a colour, [r, g, b] each 0..1. Held until reset or stop.",
        available=lambda live: bool(live.colour_dofs),
        choices={"dof": (lambda live: live.colour_dofs, "the robot's LEDs")},
        order=80,
        idempotent=True,
    )
    dof_type = "colour"
    value_field = "colour"
    type: Literal["set_led"] = "set_led"
    dof: str | None = Field(default=None, description="colour DoF; default: the robot's first")
    colour: Vec3 = Field(..., description="[r, g, b], each within 0..1")

    @field_validator("colour")
    @classmethod
    def _range(cls, v: Vec3) -> Vec3:
        if not all(0.0 <= c <= 1.0 for c in v):
            raise ValueError("colour components must be within [0, 1]")
        return v

    def value(self) -> Any:
        return list(self.colour)


class SetFace(_Display):
    """Show a face/screen expression (an option of an enum display DoF)."""

    acts_on = Target(blocks=("face",), role="engine", what="face block")
    ai_tool = AiTool(
        "set_face",
        "Show a facial expression on the robot's face display. Held until reset or stop.",
        available=lambda live: bool(live.enum_dofs),
        choices={
            "expression": (lambda live: live.expressions, "the expressions"),
            "dof": (lambda live: live.enum_dofs, "the robot's face displays"),
        },
        order=90,
        idempotent=True,
    )
    dof_type = "enum"
    value_field = "expression"
    type: Literal["set_face"] = "set_face"
    dof: str | None = Field(default=None, description="enum display DoF; default: the robot's first")
    expression: str = Field(..., description="an option of that DoF (e.g. smile)")

    def value(self) -> Any:
        return self.expression
