"""The posture block: go to a named pose of the robot's pose library with a duration and an easing."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field

from backend.engine.asset_errors import LibraryError, NotFound
from backend.engine.blocks.base import BlockCommandError, BlockParams, Port, PortType, Source
from backend.engine.blocks.core import pose_vector
from backend.engine.blocks.quiet import QuietWhenIdle
from backend.engine.frames import PartialFrame, SteadyFrame

log = logging.getLogger(__name__)

Easing = Literal[
    "linear", "sine_in_out", "quad_in_out", "cubic_in_out", "quint_in_out", "back_out", "elastic_out"
]


def ease(name: str, u: float) -> float:
    """Easing curves on u in [0, 1] (0 -> 0, 1 -> 1). back/elastic overshoot on purpose (anticipation and
    follow-through, the paper's principles); the output block clamps to limits, the NMF smooths."""
    u = min(max(u, 0.0), 1.0)
    if name == "linear":
        return u
    if name == "sine_in_out":
        return 0.5 - 0.5 * math.cos(math.pi * u)
    if name in ("quad_in_out", "cubic_in_out", "quint_in_out"):
        p = {"quad_in_out": 2, "cubic_in_out": 3, "quint_in_out": 5}[name]
        return 0.5 * (2 * u) ** p if u < 0.5 else 1 - 0.5 * (2 - 2 * u) ** p
    if name == "back_out":
        c1 = 1.70158
        return 1 + (c1 + 1) * (u - 1) ** 3 + c1 * (u - 1) ** 2
    if name == "elastic_out":
        if u in (0.0, 1.0):
            return u
        return 2 ** (-10 * u) * math.sin((u * 10 - 0.75) * (2 * math.pi / 3)) + 1
    raise ValueError(f"unknown easing '{name}'")


class PostureParams(BlockParams):
    posture: str | None = Field(
        default=None,
        description="posture to hold at start (from the robot's pose library)",
        json_schema_extra={"x-widget": "posture"},
    )
    duration: float = Field(default=1.0, ge=0.05, le=10.0, description="time to reach a new posture (s)")
    easing: Easing = Field(
        default="sine_in_out", description="slow in/out by default; back/elastic overshoot"
    )


class Posture(QuietWhenIdle, Source[PostureParams]):
    """Goes to a named posture of the robot (happy, sad, curious, …) with a duration and an easing.

    Run-time command `go {posture, duration?, easing?}` (the API's go_posture) starts a move from where
    the block's output is now, reporting started/completed (or cancelled when another move replaces
    it). Enum channels such as the mouth expression switch half-way. Only the posture's DoFs are set.
    """

    type_name = "posture"
    title = "Posture"
    outputs = {"out": Port(PortType.frame, "the pose"), "moving": Port(PortType.bool, "true while moving")}

    @dataclass
    class State:
        current: np.ndarray  # the pose output now
        mask: np.ndarray  # the DoFs set by any posture so far
        start: np.ndarray  # the pose the running move started from
        target: np.ndarray  # the pose it goes to
        elapsed: float = 0.0  # s into the move
        move: dict[str, Any] | None = None  # the running move {posture, duration, easing}
        command_id: Any = None

    def reset(self) -> None:
        current = self.emb.rest.copy()
        mask = np.zeros(self.emb.n_channels, dtype=bool)
        if self.params.posture:
            vec, mask = self._pose(self.params.posture)
            current = np.where(mask, vec, current)
        self.state = self.State(current=current, mask=mask, start=current.copy(), target=current.copy())

    def _pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        values = None
        lib = self.ctx.resources
        if lib is not None:
            try:
                doc = lib.get("postures", name)
                values = doc.get("values", doc)
            except NotFound:
                values = None  # not in the library: perhaps one the robot's embodiment declares
            except LibraryError as exc:  # a posture file that cannot be read: say so, fall back
                log.warning("posture '%s' in the library is unusable (%s); trying the robot's own", name, exc)
                values = None
        if values is None:
            values = self.emb.postures.get(name)
        if values is None:
            raise BlockCommandError(
                f"robot '{self.emb.name}' has no posture '{name}' (postures: {sorted(self.emb.postures)})"
            )
        try:
            return pose_vector(self.emb, {k: v for k, v in values.items() if k not in ("name", "builtin")})
        except ValueError as exc:
            raise BlockCommandError(f"posture '{name}': {exc}") from exc

    def configure(self) -> None:
        if self.params.posture:
            self._pose(self.params.posture)  # an unknown posture is a configuration error, reported by name

    def move_status(self) -> dict[str, Any] | None:
        """The running move, for status reports: {posture, command_id, elapsed (s), duration (s),
        progress (0..1)}; None when the block holds still."""
        s = self.state
        if s.move is None:
            return None
        duration = s.move["duration"]
        return {
            "posture": s.move["posture"],
            "command_id": s.command_id,
            "elapsed": round(s.elapsed, 3),
            "duration": duration,
            "progress": round(min(s.elapsed / duration, 1.0), 3),
        }

    def handle(self, command: str, args: dict[str, Any]) -> Any:
        if command == "go":
            name = str(args.get("posture", ""))
            vec, mask = self._pose(name)
            duration = float(args.get("duration") or self.params.duration)
            easing = str(args.get("easing") or self.params.easing)
            ease(easing, 0.5)  # validates the name
            s = self.state
            self._cancel_move()
            s.start = s.current.copy()
            s.target = np.where(mask, vec, s.current)
            s.mask = s.mask | mask
            s.elapsed = 0.0
            s.move = {"posture": name, "duration": duration, "easing": easing}
            s.command_id = args.get("command_id")
            self.ctx.notify(self.node_id, "started", command_id=s.command_id, posture=name)
            return {"posture": name, "duration": duration}
        if command in ("stop", "cancel"):
            self._cancel_move()
            self.state.move = None
            self.state.target = self.state.current.copy()
            return {"stopped": True}
        return super().handle(command, args)

    def _cancel_move(self) -> None:
        s = self.state
        if s.move is not None:
            self.ctx.notify(self.node_id, "cancelled", command_id=s.command_id, posture=s.move["posture"])

    def tick(self, dt: float, inputs: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        if s.move is not None:
            s.elapsed += dt
            u = s.elapsed / s.move["duration"]
            k = ease(s.move["easing"], u)
            cont = s.start + k * (s.target - s.start)
            s.current = np.where(self.emb.enum_mask, np.where(u >= 0.5, s.target, s.start), cont)
            if u >= 1.0:
                s.current = s.target.copy()
                self.ctx.notify(
                    self.node_id,
                    "completed",
                    command_id=s.command_id,
                    posture=s.move["posture"],
                    _channels=tuple(np.flatnonzero(s.mask).tolist()),  # what the move moved (action watch)
                )
                s.move = None
        self.quiet = s.move is None  # held: nothing changes until a command (quiet.py)
        if s.move is not None:
            return {"out": PartialFrame(s.current.copy(), s.mask, []), "moving": True}
        # Held (most ticks): one frame until the pose changes (`current` and `mask` are replaced, never
        # changed in place).
        held = self.__dict__.get("_held")
        if held is None or held[0] is not s.current or held[1] is not s.mask:
            held = self._held = (s.current, s.mask, SteadyFrame(s.current.copy(), s.mask, []))
        return {"out": held[2], "moving": False}
