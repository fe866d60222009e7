"""What a command sees of the session it runs in: the seam between the commands and
`backend.session.EngineSession`, which imports them (so they name this Protocol, not the class)."""

from __future__ import annotations

from typing import Protocol

from backend.engine.embodiment import Embodiment
from backend.engine.library import RobotLibrary
from backend.engine.runtime import Engine
from backend.graph.schema import Program


class CommandSession(Protocol):
    """The running engine, its robot and library, the running program document, and a reset."""

    @property
    def engine(self) -> Engine: ...

    @property
    def embodiment(self) -> Embodiment: ...

    @property
    def library(self) -> RobotLibrary: ...

    @property
    def program(self) -> Program | None: ...

    def reset(self, fade: float | None = None) -> None:
        """The running program as it starts, reached over `fade` seconds within the robot's limits."""
        ...
