"""The running program's exposed inputs and its layers: set inputs, set the mood, fade layers."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from backend.control.ai import AiTool, input_value_schema
from backend.control.base import BaseCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.control.targets import declares_input, mixers, set_inputs

INPUTS = Target(role="input", what="exposed input")


def _input_values(live: Any, schema: dict[str, Any]) -> None:
    """`values` as an object of the program's exposed inputs, each with its own type and range."""
    schema["properties"]["values"] = {
        "type": "object",
        "minProperties": 1,
        "additionalProperties": False,
        "properties": {decl.name: input_value_schema(decl) for decl in live.inputs},
        "description": "exposed input name -> value; all are set at the same tick, or none if one is wrong",
    }


def _emotion_notes(live: Any) -> str:
    parts = [
        f"{d.name}: {d.description}"
        for d in (live.input("valence"), live.input("arousal"))
        if d is not None and d.description
    ]
    return (
        "The mood stays until changed; it shapes idle motion, breathing and posture. " + "; ".join(parts)
    ).strip()


def _emotion_ranges(live: Any, schema: dict[str, Any]) -> None:
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


class SetInput(BaseCommand):
    """Set one exposed input of the running program."""

    acts_on = INPUTS
    type: Literal["set_input"] = "set_input"
    name: str
    value: Any

    def run(self, ctx: CommandContext) -> Any:
        return set_inputs(ctx.session, {self.name: self.value})


class SetInputs(BaseCommand):
    """Set several exposed inputs at the same tick."""

    acts_on = INPUTS
    ai_tool = AiTool(
        "set_inputs",
        "Set exposed inputs of the running program (its live controls) at the same tick.",
        available=lambda live: bool(live.inputs),
        shape=_input_values,
        order=50,
        idempotent=True,
    )
    type: Literal["set_inputs"] = "set_inputs"
    values: dict[str, Any]

    def run(self, ctx: CommandContext) -> Any:
        return set_inputs(ctx.session, self.values)


class SetLayer(BaseCommand):
    """Activate or deactivate a layer of a layer mixer, fading over `fade` seconds."""

    acts_on = Target(role="mixer", what="layer mixer")
    ai_tool = AiTool(
        "set_layer",
        "Switch a layer of the running program's motion on or off, fading over `fade` seconds.",
        available=lambda live: bool(live.layers),
        choices={"layer": (lambda live: live.layers, "the program's layers")},
        order=100,
        idempotent=True,
    )
    type: Literal["set_layer"] = "set_layer"
    layer: str = Field(..., description="name of a layer of the program's layer mixer")
    active: bool = Field(default=True, description="on (true) or off")
    fade: float | None = Field(
        default=None, ge=0.0, le=30.0, description="fade time (s; default: the layer's)"
    )
    mixer: str | None = Field(
        default=None, description="mixer node id; default: the mixer that has this layer"
    )

    def run(self, ctx: CommandContext) -> Any:
        candidates = [m for m in mixers(ctx.session) if not self.mixer or m.node_id == self.mixer]
        mixer = next((m for m in candidates if self.layer in getattr(m, "names", ())), None)
        if mixer is None:
            raise CommandError(f"no layer mixer has a layer '{self.layer}'", field="layer", code="no_target")
        ctx.session.engine.call(lambda: mixer.set_layer_active(self.layer, self.active, self.fade))
        return {"layer": self.layer, "active": self.active}


class SetEmotion(BaseCommand):
    """Set the program's `valence` and `arousal` inputs (-1..1)."""

    acts_on = Target(role="input", what="valence/arousal inputs")
    ai_tool = AiTool(
        "set_emotion",
        "Set the robot's mood: valence (unpleasant to pleasant) and arousal (calm to excited).",
        available=lambda live: live.input("valence") is not None or live.input("arousal") is not None,
        notes=_emotion_notes,
        shape=_emotion_ranges,
        order=40,
        idempotent=True,
    )
    type: Literal["set_emotion"] = "set_emotion"
    valence: float = Field(..., ge=-1.0, le=1.0)
    arousal: float = Field(..., ge=-1.0, le=1.0)

    def run(self, ctx: CommandContext) -> Any:
        names = [n for n in ("valence", "arousal") if declares_input(ctx.session, n)]
        if not names:
            raise CommandError("the running program declares no 'valence'/'arousal' inputs", code="no_target")
        return set_inputs(ctx.session, {n: getattr(self, n) for n in names})
