"""Where the robot is and looks: go to a named posture, look at a point."""

from __future__ import annotations

import contextlib
from typing import Annotated, Any, Literal, get_args

from pydantic import Field

from backend.control.ai import AiTool, Choice
from backend.control.base import BaseCommand, BlockCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.control.session_view import CommandSession
from backend.control.targets import blocks_of, declares_input, set_inputs, tell
from backend.engine.blocks.base import Block

Vec3 = tuple[float, float, float]
#: How far (m, along each axis of the robot's base frame) a gaze target may lie: beyond a few metres a
#: point looks the same as one farther along its direction, and far beyond it a number is a mistake.
GAZE_REACH = 20.0
_Reach = Annotated[float, Field(ge=-GAZE_REACH, le=GAZE_REACH)]
GazePoint = tuple[_Reach, _Reach, _Reach]


def _easings(live: Any) -> list[Choice]:
    from backend.engine.blocks.posture import Easing  # only when tools are built: commands load no blocks

    return [Choice(e) for e in get_args(Easing)]


def _gaze_notes(live: Any) -> str:
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


class GoPosture(BlockCommand):
    """Go to a named posture of the robot's pose library."""

    acts_on = Target(blocks=("posture",), what="posture block")
    long_action = True
    ai_tool = AiTool(
        "set_posture",
        "Move to one of the robot's named postures (a held pose) over `duration` seconds.",
        available=lambda live: live.has("posture") and bool(live.postures),
        choices={
            "posture": (lambda live: live.postures, "the robot's postures"),
            "easing": (_easings, "the easing curves"),
        },
        order=20,
        idempotent=True,
    )
    type: Literal["go_posture"] = "go_posture"
    posture: str = Field(..., min_length=1, max_length=80, description="name of a posture of the robot")
    duration: float | None = Field(
        default=None, gt=0.0, le=30.0, description="time to get there (s; default: the block's)"
    )
    easing: str | None = Field(default=None, description="easing curve of the move (default: the block's)")

    def run(self, ctx: CommandContext) -> Any:
        return self.tell(ctx, self.block(ctx.session), "go", self.args())

    @classmethod
    def stop_owned(cls, block: Block, command_id: str) -> None:
        s = block.state
        if s.command_id == command_id and s.move is not None:
            block.handle("stop", {"command_id": command_id})


class SetGaze(BaseCommand):
    """Look at a point (m, robot base frame): sets the program's `gaze_target` input. A long action: it
    answers whether the point is within the gaze's reach (and if not, where the gaze stops), and
    completes when the gaze has arrived, or stopped at its limit (`reached` says which)."""

    acts_on = Target(blocks=("gaze",), role="input", what="gaze_target input")
    long_action = True
    ai_tool = AiTool(
        "look_at",
        "Look at a point in space (the gaze follows it smoothly, head first, body after).",
        available=lambda live: live.input("gaze_target") is not None,
        notes=_gaze_notes,
        order=30,
        idempotent=True,
    )
    type: Literal["set_gaze"] = "set_gaze"
    target: GazePoint = Field(
        ...,
        description=f"[x, y, z] (m) in the robot's base frame: x forward, y left, z up; "
        f"each within +-{GAZE_REACH:g} m",
    )

    def run(self, ctx: CommandContext) -> Any:
        if not declares_input(ctx.session, "gaze_target"):
            raise CommandError("the running program declares no 'gaze_target' input", code="no_target")
        result = set_inputs(ctx.session, {"gaze_target": list(self.target)})
        gazes = blocks_of(ctx.session, self.acts_on.blocks)
        if not gazes:  # no gaze block follows the input: nothing moves that could be waited for
            return {**result, "done": True}
        block: Any = gazes[0]  # a Gaze block (blocks_of types them as Block)
        reach = ctx.session.engine.call(lambda: block.reach(self.target))
        tell(ctx.session, block, "watch", {"command_id": ctx.command_id})
        return {**result, **reach}

    @classmethod
    def cancel(cls, session: CommandSession, command_id: str) -> None:
        for block in blocks_of(session, ("gaze",)):
            with contextlib.suppress(Exception):  # a block that cannot stop: reported cancelled regardless
                session.engine.call(lambda b=block: b.handle("unwatch", {"command_id": command_id}))
