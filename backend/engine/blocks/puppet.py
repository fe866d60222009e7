"""The puppet block: a live pose streamed by a client (Blender's live link), with a watchdog."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import Field

from backend.engine.blocks.base import BlockParams, DofSelection, Port, PortType, Source
from backend.engine.blocks.quiet import QuietWhenIdle
from backend.engine.embodiment import DofType
from backend.engine.frames import PartialFrame, SteadyFrame
from backend.engine.selectors import channel_mask


class PuppetParams(BlockParams):
    dofs: DofSelection = Field(default=["*"], description="DoFs a client may puppeteer (others are refused)")
    timeout: float = Field(
        default=0.5,
        ge=0.05,
        le=10.0,
        description="watchdog: with no message for this long (s, engine "
        "time) the stream counts as dropped and fades out",
    )
    fade_in: float = Field(default=0.3, ge=0.0, le=5.0, description="blend-in time when a stream starts (s)")
    fade_out: float = Field(
        default=0.5, ge=0.0, le=5.0, description="blend-out time when the stream ends or drops (s)"
    )


class PuppetValueError(ValueError):
    """A puppet target that does not fit the robot or the block; `dof` names it."""

    def __init__(self, message: str, dof: str):
        super().__init__(message)
        self.dof = dof


class Puppet(QuietWhenIdle, Source[PuppetParams]):
    """Holds the pose a client streams with `puppet` commands (Blender's live link), for a puppet layer.

    Each `puppet` command sets the targets of the DoFs it names (the others keep theirs). While messages
    keep coming, the `weight` output (wire it to the mixer's `<layer>_weight`) rises to 1 over `fade_in`;
    when they stop for longer than `timeout` (the link dropped) or a `release` arrives, it falls to 0 over
    `fade_out` and the targets are forgotten. Put the layer on top of the mixer in override mode: the
    robot then follows the client's pose, through stage 2 (the motion filter, the safety limits) like any
    other layer.
    """

    type_name = "puppet"
    title = "Puppet (live link)"
    outputs = {
        "out": Port(PortType.frame, "the streamed pose on the DoFs the client set"),
        "weight": Port(PortType.float, "blend envelope 0..1 (wire to the mixer's layer weight)"),
        "live": Port(PortType.bool, "true while messages arrive within the timeout"),
    }

    @dataclass
    class State:
        values: np.ndarray  # (C,) the latest targets
        mask: np.ndarray  # (C,) channels set since the stream started
        env: float = 0.0  # blend envelope 0..1
        live: bool = False  # a stream is on
        silence: float = 0.0  # s of engine time since the last message

    def configure(self) -> None:
        self.allowed = channel_mask(self.emb, self.params.dofs)

    def reset(self) -> None:
        n = self.emb.n_channels
        self.state = self.State(values=self.emb.rest.copy(), mask=np.zeros(n, dtype=bool))
        self._nothing = np.zeros(n, dtype=bool)

    # --- commands (`resolve` runs in the caller's thread: it only reads the robot and the parameters) ---
    def resolve(self, targets: dict[str, Any]) -> tuple[list[int], list[float]]:
        """Channel indices and values for `{dof: target}`; PuppetValueError names the first that does not
        fit: continuous targets within the DoF's position limits (rad or m), colours [r, g, b] in 0..1,
        expressions an option name. Nothing is changed."""
        channels: list[int] = []
        values: list[float] = []
        for name, target in targets.items():
            if not self.emb.has_dof(name):
                raise PuppetValueError(f"robot '{self.emb.name}' has no DoF '{name}'", name)
            dof = self.emb.dof(name)
            sl = dof.channels
            if dof.type is DofType.event or not self.allowed[sl].all():
                why = (
                    "is an event DoF"
                    if dof.type is DofType.event
                    else f"is not in its dofs {self.params.dofs}"
                )
                raise PuppetValueError(f"puppet block '{self.node_id}' cannot set '{name}': it {why}", name)
            channels.extend(range(sl.start, sl.stop))
            values.extend(self._channel_values(dof, target))
        return channels, values

    @staticmethod
    def _channel_values(dof: Any, target: Any) -> list[float]:
        name = dof.name
        if dof.type is DofType.continuous:
            if isinstance(target, bool) or not isinstance(target, (int, float)) or not math.isfinite(target):
                raise PuppetValueError(f"'{name}' takes a number (rad or m), got {target!r}", name)
            slack = 1e-9 * max(1.0, dof.max - dof.min)  # float round-off of a value read back from a DCC tool
            if not dof.min - slack <= target <= dof.max + slack:
                raise PuppetValueError(
                    f"'{name}' = {target:g} is outside its limits [{dof.min:g}, {dof.max:g}]", name
                )
            return [min(max(float(target), dof.min), dof.max)]
        if dof.type is DofType.colour:
            if not (
                isinstance(target, list)
                and len(target) == 3
                and all(
                    isinstance(c, (int, float)) and not isinstance(c, bool) and 0.0 <= c <= 1.0
                    for c in target
                )
            ):
                raise PuppetValueError(
                    f"'{name}' takes a colour [r, g, b] with components in 0..1, got {target!r}", name
                )
            return [float(c) for c in target]
        options = list(dof.options or ())
        if not isinstance(target, str) or target not in options:
            raise PuppetValueError(f"'{name}' takes one of {options}, got {target!r}", name)
        return [float(options.index(target))]

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        s = self.state
        if command == "set":
            self._idle = None  # the values change in place
            channels = np.asarray(args.get("channels", []), dtype=np.intp)
            s.values[channels] = np.asarray(args.get("values", []), dtype=float)
            s.mask[channels] = True
            s.live, s.silence = True, 0.0
            return {"live": True, "channels": int(channels.size)}
        if command == "release":
            was = s.live
            s.live = False
            return {"live": False, "released": was}
        return super().handle(command, args)

    # --- tick -----------------------------------------------------------------------------------------
    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s, p = self.state, self.params
        self.quiet = False
        if s.live:  # the watchdog counts while streamed to (`set` restarts it): time is not counted idle
            s.silence += dt
            if s.silence > p.timeout:
                s.live = False  # the client stopped or dropped
        # The envelope is one number: scalar arithmetic, the same as blend.advance_fades on a (1,) array
        # at a fraction of its cost (this block runs every tick of a program, streamed to or not).
        target, fade = (1.0, p.fade_in) if s.live else (0.0, p.fade_out)
        step = dt / max(fade, 1e-9) if fade > 0.0 else math.inf
        env = s.env = min(max(s.env + min(max(target - s.env, -step), step), 0.0), 1.0)
        if env <= 0.0:
            if s.live:
                return {"out": PartialFrame(s.values.copy(), self._nothing, []), "weight": 0.0, "live": True}
            # Faded out and not streamed to (most ticks of most programs): one frame until a `set`.
            idle = self.__dict__.get("_idle")
            if idle is None or idle[0] is not s or idle[1].mask is not self._nothing:
                s.mask[:] = False  # the next stream starts from nothing
                idle = self._idle = (s, SteadyFrame(s.values.copy(), self._nothing, []))
            self.quiet = True  # faded out, not streamed to: until a `set` (quiet.py)
            return {"out": idle[1], "weight": 0.0, "live": False}
        weight = env * env * (3.0 - 2.0 * env)  # smoothstep: no kink where the fade starts or ends
        return {"out": PartialFrame(s.values.copy(), s.mask.copy(), []), "weight": weight, "live": s.live}
