"""Bypass: a block switched off in the program passes its first frame input through unchanged.

Like Houdini's bypass flag or Blender's mute (M), bypassing keeps the node, its wires and its
parameters in the document (`"bypass": true` on the node) while the engine runs a pass-through in its
place, so an animator can compare the motion with and without an operator without rewiring.

Only blocks that take a frame and give a frame (operators, mixers, stage-2 filters) can be bypassed:
the output block and sources have nothing to pass through, and a block that guards the robot (the
safety limiter, `can_bypass = False`) is never switched off from the editor. A bypassed block still builds and checks
its parameters (its errors are shown, so un-bypassing cannot surprise); its other outputs give nothing.
"""

from __future__ import annotations

from functools import cache
from typing import Any

from backend.engine.blocks.base import Block, BlockParams, PortType


def pass_through(cls: type[Block], params: BlockParams | None) -> tuple[str, str] | None:
    """(input, output) port names a bypass of `cls` with `params` connects (None: it cannot be bypassed)."""
    if not cls.bypassable():
        return None
    inputs, outputs = cls.ports(params)
    first_in = next((name for name, p in inputs.items() if p.type is PortType.frame), None)
    first_out = next((name for name, p in outputs.items() if p.type is PortType.frame), None)
    return (first_in, first_out) if first_in and first_out else None


def _configure_passing(self: Block) -> None:
    type(self).__mro__[1].configure(self)  # the real block's configuration: its errors still surface
    # kept in the instance's own dict: the port names the tick hands the frame between
    self.__dict__["_bypass_ports"] = pass_through(type(self), self.params)


def _tick_passing(self: Block, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
    ports = self.__dict__["_bypass_ports"]
    return {} if ports is None else {ports[1]: inputs.get(ports[0])}


@cache
def bypassed(cls: type[Block]) -> type[Block]:
    """A subclass of `cls` whose tick hands its first frame input to its first frame output.

    A plain subclass with two methods replaced, so everything the class machinery derives (ports,
    drivable parameters, the parameter model) is the real block's."""
    namespace = {"configure": _configure_passing, "tick": _tick_passing, "bypassed": True}
    return type(f"Bypassed{cls.__name__}", (cls,), namespace)
