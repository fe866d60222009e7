"""The whole program at once: start it afresh, stop everything, cancel one command by id."""

from __future__ import annotations

import contextlib
from typing import Any, Literal

from pydantic import Field

from backend.control.ai import AiTool, ToolArgumentError
from backend.control.base import REGISTRY, BaseCommand, CommandContext, Target
from backend.control.clips import StopClip
from backend.control.errors import CommandError
from backend.control.targets import blocks_of, set_inputs, tell


class Reset(BaseCommand):
    """Start the running program afresh: long actions are cancelled, every block, layer and exposed
    input is as the program declares it, display overrides are cleared; the robot blends there over
    `fade` seconds (longer if its limits need it)."""

    acts_on = Target(role="engine", what="running program")
    type: Literal["reset"] = "reset"
    fade: float = Field(default=1.0, ge=0.0, le=30.0)

    def run(self, ctx: CommandContext) -> Any:
        # Long actions end as cancelled (their blocks are about to be replaced), then the program
        # starts afresh as it declares itself: layers, inputs, no overrides.
        busy = tuple({name for cls in REGISTRY.classes() if cls.long_action for name in cls.acts_on.blocks})
        ctx.session.behaviours.stop_all()
        for block in blocks_of(ctx.session, busy):
            with contextlib.suppress(CommandError):  # a block with nothing to stop
                tell(ctx.session, block, "stop", {"fade": 0.0})
        ctx.session.reset(fade=self.fade)
        return {"reset": True}


def _stop_route(args: dict[str, Any]) -> dict[str, Any]:
    """The stop tool: with a layer, stop_clip on it; without, stop_all."""
    if args.get("layer"):
        return {"type": "stop_clip", **args}
    if args.get("fade") is not None:
        raise ToolArgumentError(
            "fade applies to one layer's clip: give 'layer' too (stop without a layer stops "
            "everything at once)",
            field="fade",
        )
    return {"type": "stop_all"}


class StopAll(BaseCommand):
    """Stop everything now: behaviours, clips, pending actions, overrides; exposed inputs back to their
    defaults."""

    acts_on = Target(blocks=("clip_player",), role="engine", what="running program")
    # One tool for both stops: its arguments are stop_clip's, and `layer` decides which is sent.
    ai_tool = AiTool(
        "stop",
        "Stop: with `layer`, the clip playing on that layer (fading out over `fade` s); without, "
        "everything at once (behaviours, clips, held LEDs and faces; exposed inputs back to their defaults).",
        fields=StopClip,
        layer_choice=True,
        route=_stop_route,
        order=900,
        idempotent=True,
        destructive=True,
    )
    type: Literal["stop_all"] = "stop_all"

    def run(self, ctx: CommandContext) -> Any:
        session = ctx.session
        session.behaviours.stop_all()  # first: a behaviour would go on starting its next items
        for block in blocks_of(session, self.acts_on.blocks):
            tell(session, block, "stop", {"fade": 0.0})
        session.engine.call(session.engine.clear_overrides)
        if session.program is not None:
            defaults = {i.name: i.default for i in session.program.inputs}
            if defaults:
                set_inputs(session, defaults)
        return {"stopped": True}


class Cancel(BaseCommand):
    """Cancel a long action by the id it was given."""

    acts_on = Target(role="command", what="command")
    ai_tool = AiTool(
        "cancel",
        "Cancel a long action (a clip, a posture move, speech) by the id a tool answered with; "
        "it ends as `cancelled`. Other actions go on.",
        order=910,
        idempotent=True,
        destructive=True,
    )
    type: Literal["cancel"] = "cancel"
    target: str = Field(..., description="id of the command to cancel")

    def run(self, ctx: CommandContext) -> Any:
        if ctx.cancel is None:
            raise CommandError(
                f"no command with id '{self.target}' (only a server keeps commands by id)",
                field="target",
                code="unknown_command",
            )
        return ctx.cancel(self.target)
