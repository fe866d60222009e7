"""The tools an AI is offered, declared once: which command each one sends, when the running program
can carry it out, and which of its arguments take a value from the live robot, program or library.

Everything else is generated (backend.tools.build): the argument schemas come from the command models
(backend.control), the enums and their one-line descriptions from the robot's library and program
(backend.tools.live). A tool whose command the running program cannot carry out is not offered.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, get_args

from pydantic import BaseModel, ConfigDict, Field

from backend import control
from backend.engine.blocks.posture import Easing
from backend.tools.live import Choice, Live

MAX_WAIT = 120.0  # s: the longest a tool call may wait for its action to end
DEFAULT_WAIT = 30.0  # s


class WaitOptions(BaseModel):
    """How long a tool call waits for its action (every long-action tool, and get_status with an id)."""

    model_config = ConfigDict(extra="forbid")
    wait: bool = Field(
        False,
        description="answer only once the action has ended (completed or cancelled), "
        "or `timeout` has passed; otherwise answer at once with its id",
    )
    timeout: float = Field(
        DEFAULT_WAIT,
        gt=0.0,
        le=MAX_WAIT,
        description=f"longest wait (s, at most {MAX_WAIT:g}); the action goes on after it",
    )


class StatusArguments(WaitOptions):
    """get_status: the robot's activity, and one command's status when `id` is given."""

    id: str | None = Field(
        None,
        max_length=64,
        description="a command id from an earlier answer: report its "
        "status too (with `wait`: once it has ended)",
    )


Choices = Callable[[Live], list[Choice]]


@dataclass(frozen=True)
class ToolSpec:
    """One tool: its name, the command it sends (`command`, whose fields are its arguments unless
    `fields` names another model), when it is offered (`available`), which arguments are enums of what
    exists now (`choices`: argument -> (values, what they are)), fields not offered (`hide`), generated
    notes for its description, a last adjustment of its argument schema (`shape`), and how its
    arguments become a command (`route`; default: the command with those fields)."""

    name: str
    summary: str
    command: type | None
    available: Callable[[Live], bool]
    choices: dict[str, tuple[Choices, str]] = field(default_factory=dict)
    hide: tuple[str, ...] = ()
    fields: type | None = None
    layer_choice: bool = False  # offer `layer` even when the program has one target block
    notes: Callable[[Live], str] | None = None
    shape: Callable[[Live, dict[str, Any]], None] | None = None
    route: Callable[[dict[str, Any]], dict[str, Any]] | None = None

    @property
    def model(self) -> type:
        return self.fields or self.command or StatusArguments


def _gaze_notes(live: Live) -> str:
    decl = live.input("gaze_target")
    ranges = "; ".join(f"{axis} {lo:g}..{hi:g} rad" for axis, (lo, hi) in live.gaze_range.items())
    return (
        "`target` is a point [x, y, z] in metres in the robot's base frame: x forward, y to the robot's "
        "left, z up. The head and body turn toward it "
        + (
            f"as far as the gaze joints reach ({ranges}; yaw + is left, pitch + is down); "
            if ranges
            else "; "
        )
        + "a point beyond that is looked toward as far as they go, and the robot's limits always hold."
        + (f" Looking straight ahead: {decl.default}." if decl is not None else "")
    )


def _emotion_notes(live: Live) -> str:
    parts = [
        f"{d.name}: {d.description}"
        for d in (live.input("valence"), live.input("arousal"))
        if d is not None and d.description
    ]
    return (
        "The mood stays until changed; it shapes idle motion, breathing and posture. " + "; ".join(parts)
    ).strip()


def _emotion_ranges(live: Live, schema: dict[str, Any]) -> None:
    """The program's own ranges and descriptions of valence and arousal, within the command's."""
    for name in ("valence", "arousal"):
        decl, prop = live.input(name), schema["properties"].get(name)
        if decl is None or prop is None:
            continue
        if decl.min is not None:
            prop["minimum"] = max(prop.get("minimum", decl.min), decl.min)
        if decl.max is not None:
            prop["maximum"] = min(prop.get("maximum", decl.max), decl.max)
        if decl.description:
            prop["description"] = decl.description


def _input_values(live: Live, schema: dict[str, Any]) -> None:
    from backend.tools.schema import input_value_schema

    schema["properties"]["values"] = {
        "type": "object",
        "minProperties": 1,
        "additionalProperties": False,
        "properties": {decl.name: input_value_schema(decl) for decl in live.inputs},
        "description": "exposed input name -> value; all are set at the same tick, or none if one is wrong",
    }


def _stop_route(args: dict[str, Any]) -> dict[str, Any]:
    from backend.tools.errors import ToolError

    if args.get("layer"):
        return {"type": "stop_clip", **args}
    if args.get("fade") is not None:
        raise ToolError(
            "fade applies to one layer's clip: give 'layer' too (stop without a layer stops "
            "everything at once)",
            field="fade",
        )
    return {"type": "stop_all"}


TOOLS: tuple[ToolSpec, ...] = (
    ToolSpec(
        "play_clip",
        "Play one of the robot's recorded moves (a gesture or an emotion clip).",
        control.PlayClip,
        lambda live: live.has("clip_player") and bool(live.clips),
        choices={"clip": (lambda live: live.clips, "the robot's clips")},
        hide=("anchors",),
    ),
    ToolSpec(
        "set_posture",
        "Move to one of the robot's named postures (a held pose) over `duration` seconds.",
        control.GoPosture,
        lambda live: live.has("posture") and bool(live.postures),
        choices={
            "posture": (lambda live: live.postures, "the robot's postures"),
            "easing": (lambda live: [Choice(e) for e in get_args(Easing)], "the easing curves"),
        },
    ),
    ToolSpec(
        "look_at",
        "Look at a point in space (the gaze follows it smoothly, head first, body after).",
        control.SetGaze,
        lambda live: live.input("gaze_target") is not None,
        notes=_gaze_notes,
    ),
    ToolSpec(
        "set_emotion",
        "Set the robot's mood: valence (unpleasant to pleasant) and arousal (calm to excited).",
        control.SetEmotion,
        lambda live: live.input("valence") is not None or live.input("arousal") is not None,
        notes=_emotion_notes,
        shape=_emotion_ranges,
    ),
    ToolSpec(
        "set_inputs",
        "Set exposed inputs of the running program (its live controls) at the same tick.",
        control.SetInputs,
        lambda live: bool(live.inputs),
        shape=_input_values,
    ),
    ToolSpec(
        "say",
        "Say a sentence aloud (with the mouth moving while it speaks).",
        control.Say,
        lambda live: live.has("say") or "speech" in live.channels,
    ),
    ToolSpec(
        "play_sound",
        "Play one of the robot's sound effects.",
        control.PlaySound,
        lambda live: live.has("play_sound") or "sound" in live.channels,
        choices={"sound": (lambda live: live.sounds, "the robot's sounds")},
    ),
    ToolSpec(
        "set_led",
        "Set an LED (or LED group) to a colour, [r, g, b] each 0..1. Held until reset or stop.",
        control.SetLed,
        lambda live: bool(live.colour_dofs),
        choices={"dof": (lambda live: live.colour_dofs, "the robot's LEDs")},
    ),
    ToolSpec(
        "set_face",
        "Show a facial expression on the robot's face display. Held until reset or stop.",
        control.SetFace,
        lambda live: bool(live.enum_dofs),
        choices={
            "expression": (lambda live: live.expressions, "the expressions"),
            "dof": (lambda live: live.enum_dofs, "the robot's face displays"),
        },
    ),
    ToolSpec(
        "set_layer",
        "Switch a layer of the running program's motion on or off, fading over `fade` seconds.",
        control.SetLayer,
        lambda live: bool(live.layers),
        choices={"layer": (lambda live: live.layers, "the program's layers")},
    ),
    ToolSpec(
        "stop",
        "Stop: with `layer`, the clip playing on that layer (fading out over `fade` s); without, "
        "everything at once (clips, held LEDs and faces; exposed inputs back to their defaults).",
        control.StopAll,
        lambda live: True,
        fields=control.StopClip,
        layer_choice=True,
        route=_stop_route,
    ),
    ToolSpec(
        "cancel",
        "Cancel a long action (a clip, a posture move, speech) by the id a tool answered with; "
        "it ends as `cancelled`. Other actions go on.",
        control.Cancel,
        lambda live: True,
    ),
    ToolSpec(
        "get_status",
        "What the robot is doing: what plays on each layer (clip, command id, progress), the "
        "posture move, where it looks, the mood and inputs, the layers' weights and the "
        "engine's health. With `id`: that command's status (and with `wait`, once it ends).",
        None,
        lambda live: True,
    ),
)
