"""Answers about the robot's sounds and behaviours: sound files, behaviour summaries, plans and
previews."""

from __future__ import annotations

from typing import Any

from pydantic import Field, RootModel

from backend.api_types.base import OpenShape, Shape


class SoundEntry(Shape):
    """GET /api/sounds (each), PUT /api/sounds/{name}: one sound file of the robot."""

    name: str
    format: str = Field(..., description="wav, ogg or flac")
    duration: float = Field(..., description="s")
    samplerate: int = Field(..., description="Hz")
    channels: int
    bytes: int
    url: str = Field(..., description="where to fetch it (relative to the server)")


class BehaviourIssue(Shape):
    """One error of a behaviour: the item and field at fault (`path` in the document)."""

    message: str
    path: str | None = None
    track: int | None = Field(default=None, description="index of the track holding the item")
    item: str | None = Field(default=None, description="id of the item (`#i` when it has none)")
    field: str | None = Field(default=None, description="the item's field (`start.anchor`, `clip`, ...)")


class BehaviourParamInfo(OpenShape):
    """A declared parameter (the format's `Param`). Open: it is the document's own declaration."""

    type: str


class BehaviourSummary(Shape):
    """GET /api/behaviours (each): what a behaviour is for and what it takes."""

    name: str
    description: str
    params: dict[str, BehaviourParamInfo]
    duration: float | None = Field(..., description="s with the default parameters (None: it has errors)")
    errors: list[BehaviourIssue] = Field(default_factory=list, description="what keeps it from playing now")


class PlannedItemInfo(Shape):
    id: str
    track: int
    kind: str
    start: float = Field(..., description="s from the behaviour's start")
    end: float
    anchors: dict[str, float] = Field(default_factory=dict, description="clip anchor -> s from the start")
    follow: str | None = Field(default=None, description="look_at: the exposed input it follows")


class BehaviourPlanned(Shape):
    """POST /api/behaviours/plan: every item's time, or every error (`valid` false)."""

    valid: bool
    duration: float
    params: dict[str, Any]
    items: list[PlannedItemInfo]
    errors: list[BehaviourIssue]


class RenderedEvent(Shape):
    t: float = Field(..., description="s from the behaviour's start")
    dof: str
    kind: str
    payload: dict[str, Any]


class BehaviourRendered(Shape):
    """POST /api/behaviours/render: the behaviour played offline through the running program."""

    rate: float = Field(..., description="frames per second of `frames`")
    duration: float
    dofs: list[str] = Field(..., description="the DoFs of each frame's values, in order")
    frames: list[list[Any]] = Field(..., description="per frame, each DoF's value (rad, m, colour, option)")
    events: list[RenderedEvent]
    items: list[PlannedItemInfo]
    item_events: list[dict[str, Any]] = Field(..., description="the behaviour's item events, with `t`")


class StoredBehaviour(RootModel[dict[str, Any]]):
    """GET /api/behaviours/{name}: a behaviour (nutty-behaviour/1)."""
