"""What a command sees of the session it runs in: the seam between the commands and
`backend.session.EngineSession`, which imports them (so they name this Protocol, not the class)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from backend.engine.embodiment import Embodiment
from backend.engine.library import RobotLibrary
from backend.engine.runtime import Engine
from backend.graph.schema import Program

if TYPE_CHECKING:  # the player imports the commands lazily; only its type is named here
    from backend.behaviours.player import BehaviourPlayer


class CommandSession(Protocol):
    """The running engine, its robot and library, the running program document, the behaviour player
    and a reset."""

    @property
    def engine(self) -> Engine: ...

    @property
    def embodiment(self) -> Embodiment: ...

    @property
    def library(self) -> RobotLibrary: ...

    @property
    def program(self) -> Program | None: ...

    @property
    def behaviours(self) -> BehaviourPlayer: ...

    def reset(self, fade: float | None = None) -> None:
        """The running program as it starts, reached over `fade` seconds within the robot's limits."""
        ...
