"""Clip commands: play, stop and seek a keyframed clip on a clip player block."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from backend.control.ai import AiTool
from backend.control.base import BlockCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.control.targets import layers_of
from backend.engine.blocks.base import Block

CLIP_PLAYER = Target(blocks=("clip_player",), what="clip player")


class PlayClip(BlockCommand):
    """Play a clip on a clip player (e.g. the one on layer 'gesture').

    While that player plays another clip, `if_busy` decides: `replace` (default) crossfades to this clip
    (the playing one and any queued ones are cancelled), `queue` starts it when the playing clip
    completes (acked `queued`; its `started` event comes then; cancellable while it waits), `reject`
    refuses with code `busy` naming the layer and the playing command's id, and changes nothing.
    """

    acts_on = CLIP_PLAYER
    long_action = True
    ai_tool = AiTool(
        "play_clip",
        "Play one of the robot's recorded moves (a gesture or an emotion clip).",
        available=lambda live: live.has("clip_player") and bool(live.clips),
        choices={"clip": (lambda live: live.clips, "the robot's clips")},
        hide=("anchors", "document", "start"),
        order=10,
    )
    type: Literal["play_clip"] = "play_clip"
    clip: str = Field(..., min_length=1, max_length=80, description="name of a clip of the robot's library")
    speed: float | None = Field(
        default=None, gt=0.0, le=5.0, description="playback speed (1 = authored timing)"
    )
    mode: Literal["once", "loop", "ping_pong"] | None = Field(
        default=None,
        description="once (default: then it completes), loop or ping_pong (both go on until stopped)",
    )
    crossfade: float | None = Field(
        default=None, ge=0.0, le=10.0, description="crossfade from the current pose (s)"
    )
    anchors: dict[str, float] | None = Field(
        default=None, description="anchor name -> time (s) it must land at"
    )
    if_busy: Literal["replace", "queue", "reject"] | None = Field(
        default=None,
        description="while another clip plays on this player: replace it (crossfade; default), queue "
        "behind it, or reject this play",
    )
    document: dict[str, Any] | None = Field(
        default=None,
        description="an unsaved clip (nutty-clip/1) to play under the name `clip` instead of the "
        "library's: the clip editor's working copy on the robot",
    )
    start: float | None = Field(
        default=None, ge=0.0, le=3600.0, description="clip time to start from (s; default 0)"
    )

    def run(self, ctx: CommandContext) -> Any:
        block = self.block(ctx.session)
        try:
            return self.tell(ctx, block, "play", self.args())
        except CommandError as exc:
            if exc.code != "busy":
                raise
            layers = layers_of(ctx.session, block.node_id)
            where = (
                f"layer {', '.join(repr(n) for n in layers)}" if layers else f"clip player '{block.node_id}'"
            )
            raise CommandError(f"{where} is busy: {exc}", field="if_busy", code="busy") from exc

    @classmethod
    def stop_owned(cls, block: Block, command_id: str) -> None:
        block.handle("stop", {"command_id": command_id})  # the player stops this play only, playing or queued


class StopClip(BlockCommand):
    """Stop the clip a clip player plays, fading out over `fade` seconds (default: the block's)."""

    acts_on = CLIP_PLAYER
    type: Literal["stop_clip"] = "stop_clip"
    fade: float | None = Field(
        default=None, ge=0.0, le=10.0, description="fade-out time (s; default: the player's release)"
    )

    def run(self, ctx: CommandContext) -> Any:
        return self.tell(ctx, self.block(ctx.session), "stop", {"fade": self.fade})


class SeekClip(BlockCommand):
    """Jump the playing clip of a clip player to time `t`."""

    acts_on = CLIP_PLAYER
    type: Literal["seek_clip"] = "seek_clip"
    t: float = Field(..., ge=0.0, description="time in the clip (s)")

    def run(self, ctx: CommandContext) -> Any:
        return self.tell(ctx, self.block(ctx.session), "seek", {"t": self.t})
