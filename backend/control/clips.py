"""Clip commands: play, stop and seek a keyframed clip on a clip player block."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from backend.control.base import BlockCommand, CommandContext, Target

CLIP_PLAYER = Target(blocks=("clip_player",), what="clip player")


class PlayClip(BlockCommand):
    """Play a clip on a clip player (e.g. the one on layer 'gesture')."""

    acts_on = CLIP_PLAYER
    long_action = True
    type: Literal["play_clip"] = "play_clip"
    clip: str = Field(..., min_length=1, max_length=80)
    speed: float | None = Field(None, gt=0.0, le=5.0, description="playback speed (1 = authored timing)")
    mode: Literal["once", "loop", "ping_pong"] | None = None
    crossfade: float | None = Field(None, ge=0.0, le=10.0, description="crossfade from the current pose (s)")
    anchors: dict[str, float] | None = Field(None, description="anchor name -> time (s) it must land at")

    def run(self, ctx: CommandContext) -> Any:
        return self.tell(ctx, self.block(ctx.session), "play", self.args())

    @classmethod
    def stop_owned(cls, block: Any, command_id: str) -> None:
        s = block.state
        if s.command_id == command_id and s.current is not None and not s.done:
            block.handle("stop", {"command_id": command_id})


class StopClip(BlockCommand):
    """Stop the clip a clip player plays, fading out over `fade` seconds (default: the block's)."""

    acts_on = CLIP_PLAYER
    type: Literal["stop_clip"] = "stop_clip"
    fade: float | None = Field(None, ge=0.0, le=10.0)

    def run(self, ctx: CommandContext) -> Any:
        return self.tell(ctx, self.block(ctx.session), "stop", {"fade": self.fade})


class SeekClip(BlockCommand):
    """Jump the playing clip of a clip player to time `t`."""

    acts_on = CLIP_PLAYER
    type: Literal["seek_clip"] = "seek_clip"
    t: float = Field(..., ge=0.0, description="time in the clip (s)")

    def run(self, ctx: CommandContext) -> Any:
        return self.tell(ctx, self.block(ctx.session), "seek", {"t": self.t})
