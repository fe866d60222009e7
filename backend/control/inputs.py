"""The running program's exposed inputs and its layers: set inputs, set the mood, fade layers."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from backend.control.base import BaseCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.control.targets import declares_input, mixers, set_inputs

INPUTS = Target(role="input", what="exposed input")


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
    type: Literal["set_inputs"] = "set_inputs"
    values: dict[str, Any]

    def run(self, ctx: CommandContext) -> Any:
        return set_inputs(ctx.session, self.values)


class SetLayer(BaseCommand):
    """Activate or deactivate a layer of a layer mixer, fading over `fade` seconds."""

    acts_on = Target(role="mixer", what="layer mixer")
    type: Literal["set_layer"] = "set_layer"
    layer: str = Field(..., description="name of a layer of the program's layer mixer")
    active: bool = Field(True, description="on (true) or off")
    fade: float | None = Field(None, ge=0.0, le=30.0, description="fade time (s; default: the layer's)")
    mixer: str | None = Field(None, description="mixer node id; default: the mixer that has this layer")

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
    type: Literal["set_emotion"] = "set_emotion"
    valence: float = Field(..., ge=-1.0, le=1.0)
    arousal: float = Field(..., ge=-1.0, le=1.0)

    def run(self, ctx: CommandContext) -> Any:
        names = [n for n in ("valence", "arousal") if declares_input(ctx.session, n)]
        if not names:
            raise CommandError("the running program declares no 'valence'/'arousal' inputs", code="no_target")
        return set_inputs(ctx.session, {n: getattr(self, n) for n in names})
