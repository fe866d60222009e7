"""The behaviour format, `nutty-behaviour/1`: a multi-modal sequence an animator writes and an AI calls.

Stored as `robots/<robot>/behaviours/<name>.json`:

    {"format": "nutty-behaviour/1",
     "description": "Greet someone: look at them, wave, say hello, look happy.",
     "params": {"name": {"type": "string", "default": "friend", "description": "who to greet"},
                "target": {"type": "vec3", "default": [1.0, 0.0, 0.3]}},
     "tracks": [
       {"name": "body", "items": [
         {"id": "look", "kind": "look_at", "target": "{target}"},
         {"id": "wave", "kind": "play_clip", "clip": "wave", "start": {"item": "look", "at": "end"}}]},
       {"name": "voice", "items": [
         {"id": "hello", "kind": "say", "text": "hello {name}",
          "start": {"item": "wave", "at": "anchor", "anchor": "beat", "offset": -0.1}}]}]}

Times are seconds. An item's `start` is a number (seconds from the behaviour's start) or a reference
to another item's start, end or (a clip's) anchor, plus an offset. A field whose whole value is
`"{param}"` takes the parameter's value (typed); a say's text substitutes `{param}` anywhere in it.
A `vec3` parameter is a point [x, y, z] (m, the robot's base frame) or the name of one of the running
program's exposed inputs, followed live while the item lasts (a perceived person, say).

Tracks are rows for people (the editor draws them as lanes); what runs when is the items' starts alone.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

BEHAVIOUR_FORMAT = "nutty-behaviour/1"
#: names of items, tracks and parameters: letters, digits and '_' (a parameter is referenced as `{name}`)
IDENT = r"^[A-Za-z_][A-Za-z0-9_]{0,39}$"
#: a field's whole value naming a parameter
PARAM_REF = r"^\{[A-Za-z_][A-Za-z0-9_]{0,39}\}$"
MAX_ITEMS = 200
MAX_TIME = 600.0  # s: the latest an item may start, and the longest it may last

Ident = Annotated[str, Field(pattern=IDENT)]
ParamRef = Annotated[str, Field(pattern=PARAM_REF, description="`{param}`: the value of a parameter")]
Vec3 = tuple[float, float, float]
Seconds = Annotated[float, Field(ge=0.0, le=MAX_TIME)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Param(_Model):
    """A parameter the caller (an AI, the editor) gives when playing the behaviour."""

    type: Literal["string", "number", "vec3", "bool"] = Field(
        ..., description="string, number, vec3 (a point [x, y, z] in m, or an exposed input's name), bool"
    )
    default: Any = Field(default=None, description="the value when the caller gives none (none: required)")
    description: str = Field(default="", max_length=300, description="what it means, for people and AIs")
    min: float | None = Field(default=None, description="lowest value (number)")
    max: float | None = Field(default=None, description="highest value (number)")
    choices: list[str] | None = Field(default=None, description="the values a string may take")


class StartRef(_Model):
    """Start relative to another item: its start, its (planned) end, or an anchor of its clip."""

    item: Ident = Field(..., description="id of the item this one is timed from")
    at: Literal["start", "end", "anchor"] = Field(default="start", description="which moment of that item")
    anchor: str | None = Field(default=None, description="the clip anchor (with at: anchor)")
    offset: float = Field(default=0.0, ge=-MAX_TIME, le=MAX_TIME, description="seconds after that moment")

    @model_validator(mode="after")
    def _anchor(self) -> StartRef:
        if (self.at == "anchor") != (self.anchor is not None):
            raise ValueError("give `anchor` exactly when `at` is 'anchor'")
        return self


Start = Annotated[
    Seconds | StartRef,
    Field(
        description="seconds from the behaviour's start, or {item, at, anchor?, offset} relative to an item"
    ),
]


class _Item(_Model):
    id: Ident = Field(..., description="unique within the behaviour; other items are timed from it")
    start: Start = 0.0
    label: str = Field(default="", max_length=80, description="a note shown on the item's bar")


class PlayClipItem(_Item):
    """Play a clip on the program's clip player (on `layer`, when given); its anchors can be retimed."""

    kind: Literal["play_clip"] = "play_clip"
    clip: str = Field(..., min_length=1, max_length=80, description="a clip of the robot, or `{param}`")
    speed: Annotated[float, Field(gt=0.0, le=5.0)] | ParamRef = Field(
        default=1.0, description="playback speed"
    )
    crossfade: float | None = Field(default=None, ge=0.0, le=10.0, description="blend in (s)")
    fade_out: float | None = Field(default=None, ge=0.0, le=10.0, description="fade out when cancelled (s)")
    layer: str | None = Field(default=None, description="the mixer layer whose clip player plays it")
    anchors: dict[str, Seconds] | None = Field(
        default=None, description="clip anchor -> seconds after the item's start it must land at"
    )


class GoPostureItem(_Item):
    """Move to a named posture."""

    kind: Literal["go_posture"] = "go_posture"
    posture: str = Field(..., min_length=1, max_length=80, description="a posture of the robot, or `{param}`")
    duration: Annotated[float, Field(gt=0.0, le=30.0)] | ParamRef | None = Field(
        default=None, description="time to get there (s)"
    )
    easing: str | None = Field(default=None, description="easing of the move (default: the block's)")


class LookAtItem(_Item):
    """Look at a point (m, the robot's base frame), or follow an exposed input while the item lasts."""

    kind: Literal["look_at"] = "look_at"
    target: Vec3 | str = Field(..., description="[x, y, z] (m), `{param}` or the name of an exposed input")
    duration: Seconds | ParamRef = Field(
        default=1.0, description="how long the item lasts (s); the gaze stays after"
    )


class SayItem(_Item):
    """Say a text (`{param}` substituted): spoken by the robot's voice, or recorded speech from `audio`."""

    kind: Literal["say"] = "say"
    text: str = Field(
        ..., min_length=1, max_length=2000, description="what is said; `{param}` is substituted"
    )
    audio: str | None = Field(default=None, description="a sound of the robot: recorded speech of the text")


class PlaySoundItem(_Item):
    """Play one of the robot's sounds."""

    kind: Literal["play_sound"] = "play_sound"
    sound: str = Field(..., min_length=1, max_length=80, description="a sound of the robot, or `{param}`")


class SetLedItem(_Item):
    """Set an LED (group) to a colour; it is held until reset, stop or another colour."""

    kind: Literal["set_led"] = "set_led"
    dof: str | None = Field(default=None, description="colour DoF (default: the robot's first)")
    colour: Vec3 | ParamRef = Field(..., description="[r, g, b] each 0..1, or `{param}`")


class SetFaceItem(_Item):
    """Show a face expression (an option of an enum display DoF)."""

    kind: Literal["set_face"] = "set_face"
    dof: str | None = Field(default=None, description="enum display DoF (default: the robot's first)")
    expression: str = Field(..., min_length=1, description="an option of that DoF, or `{param}`")


class SetEmotionItem(_Item):
    """Set the program's mood inputs."""

    kind: Literal["set_emotion"] = "set_emotion"
    valence: Annotated[float, Field(ge=-1.0, le=1.0)] | ParamRef = Field(..., description="-1..1")
    arousal: Annotated[float, Field(ge=-1.0, le=1.0)] | ParamRef = Field(..., description="-1..1")


class RampItem(_Item):
    """Move an exposed input from its value at the item's start to `to` over `duration` seconds."""

    kind: Literal["ramp"] = "ramp"
    input: str = Field(..., min_length=1, description="an exposed input of the running program")
    to: float | Vec3 | ParamRef = Field(..., description="the value it ends at (a number or [x, y, z])")
    duration: Seconds | ParamRef = Field(default=1.0, description="seconds to get there")
    easing: Literal["linear", "smooth"] = Field(default="smooth", description="smooth: slow in and out")


class WaitItem(_Item):
    """Nothing happens: a span of time other items can be timed from (a pause, a beat)."""

    kind: Literal["wait"] = "wait"
    duration: Seconds | ParamRef = Field(default=1.0, description="seconds")


Item = Annotated[
    PlayClipItem
    | GoPostureItem
    | LookAtItem
    | SayItem
    | PlaySoundItem
    | SetLedItem
    | SetFaceItem
    | SetEmotionItem
    | RampItem
    | WaitItem,
    Field(discriminator="kind"),
]
ITEM_KINDS = (
    "play_clip",
    "go_posture",
    "look_at",
    "say",
    "play_sound",
    "set_led",
    "set_face",
    "set_emotion",
    "ramp",
    "wait",
)


class Track(_Model):
    name: Ident = Field(..., description="the lane's name (body, voice, face, ...)")
    items: list[Item] = Field(default_factory=list)


class Behaviour(_Model):
    format: Literal["nutty-behaviour/1"] = BEHAVIOUR_FORMAT
    name: str | None = Field(default=None, description="set from the file name when stored")
    robot: str | None = Field(default=None, description="the robot it was written for")
    description: str = Field(default="", max_length=1000, description="what it does, shown to AIs")
    params: dict[Ident, Param] = Field(default_factory=dict)
    tracks: list[Track] = Field(default_factory=list)

    def items(self) -> list[tuple[int, int, Any]]:
        """(track index, item index, item) of every item, track after track."""
        return [(t, i, item) for t, track in enumerate(self.tracks) for i, item in enumerate(track.items)]


def behaviour_json_schema() -> dict[str, Any]:
    """The format's JSON Schema (the editor's generated types come from it)."""
    return Behaviour.model_json_schema()
