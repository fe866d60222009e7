"""The clip player's parameters and its busy error (backend/engine/blocks/clip_player.py)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from backend.engine.blocks.base import BlockCommandError, BlockParams, DofSelection, drivable, soft_range

PlayMode = Literal["once", "loop", "ping_pong"]
IfBusy = Literal["replace", "queue", "reject"]
MAX_QUEUE = 16  # plays waiting behind the current clip, at most


class ClipPlayerBusy(BlockCommandError):
    """A play with `if_busy: "reject"` while a clip plays: names the clip and the command playing it."""

    code = "busy"

    def __init__(self, node_id: str, clip: str, command_id: Any):
        super().__init__(
            f"clip player '{node_id}' is playing '{clip}' (command {command_id!r}); "
            f"use if_busy 'replace' or 'queue', or cancel that command"
        )
        self.clip, self.command_id = clip, command_id


class ClipPlayerParams(BlockParams):
    clip: str | None = Field(
        default=None,
        description="clip to play (from robots/<robot>/clips/)",
        json_schema_extra={"x-widget": "clip"},
    )
    autoplay: bool = Field(default=False, description="start playing `clip` when the program starts")
    mode: PlayMode = Field(default="once", description="once, loop, or ping_pong (forward then backward)")
    speed: float = drivable(
        Field(
            default=1.0,
            ge=0.05,
            le=5.0,
            description="playback speed (1 = authored timing)",
            json_schema_extra=soft_range(0.25, 2, 0.01),
        ),
        "overrides the speed (e.g. from an emotion mapping)",
    )
    crossfade: float = Field(
        default=0.3, ge=0.0, le=5.0, description="blend-in time from the current pose (s)"
    )
    release: float = Field(
        default=0.4, ge=0.0, le=5.0, description="blend-out time after the clip ends or stops (s)"
    )
    hold: bool = Field(
        default=False, description="after a `once` clip ends, hold its last pose instead of releasing"
    )
    dofs: DofSelection = Field(default=["*"], description="DoFs the clip may set (others are ignored)")
