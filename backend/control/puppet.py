"""Live puppeteering: a client (Blender's live link) streams target poses to the program's puppet layer."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, SkipValidation, StrictFloat, StrictInt, StrictStr

from backend.control.base import BlockCommand, CommandContext, Target
from backend.control.errors import CommandError
from backend.engine.blocks.puppet import PuppetValueError

# A target: rad or m for a continuous DoF, [r, g, b] for a colour, an option name for an expression.
# The schema shows the type; the puppet block checks each target against its DoF (`Puppet.resolve`), with
# messages that name the DoF and what it takes, so pydantic does not judge the values first.
PuppetTarget = StrictFloat | StrictInt | list[StrictFloat | StrictInt] | StrictStr
MAX_TARGETS = 256


class Puppet(BlockCommand):
    """One message of a live stream: set the puppet layer's targets for the named DoFs.

    The puppet block (`puppet`) holds each DoF's latest target and fades its layer in while messages
    come; when they stop for longer than its `timeout` (0.5 s in the bundled programs), or on
    `release: true`, the layer fades out. The pose still goes through the program's stage 2 (motion
    filter, IK, safety limiter) and the engine's safety net. A target outside a DoF's limits, an unknown
    DoF or one the block may not set is refused (the field names it) and nothing changes.
    """

    acts_on = Target(blocks=("puppet",), what="puppet block")
    type: Literal["puppet"] = "puppet"
    values: SkipValidation[dict[str, PuppetTarget]] = Field(
        default_factory=dict,
        description="DoF name -> target: rad/m within the DoF's limits, [r, g, b] in 0..1, or an option name",
    )
    release: bool = Field(
        default=False, description="end the stream now: the layer fades out (give no values)"
    )

    def run(self, ctx: CommandContext) -> Any:
        if not isinstance(self.values, dict) or len(self.values) > MAX_TARGETS:
            raise CommandError(
                f"puppet: 'values' is an object of at most {MAX_TARGETS} DoF -> target", field="values"
            )
        if self.release and self.values:
            raise CommandError("puppet: give either 'values' or 'release': true, not both", field="release")
        if not self.release and not self.values:
            raise CommandError("puppet: give 'values' ({dof: target}) or 'release': true", field="values")
        block = self.block(ctx.session)
        if self.release:
            return self.tell(ctx, block, "release", {})

        try:
            channels, values = block.resolve(self.values)  # checked here, so a bad message changes nothing
        except PuppetValueError as exc:
            raise CommandError(f"puppet: {exc}", field=f"values.{exc.dof}") from exc
        result = self.tell(ctx, block, "set", {"channels": channels, "values": values})
        return {**result, "dofs": list(self.values)}
