"""The graph's document kinds in the robot's library: programs and subgraphs, checked against their
formats (`backend.graph.schema`) before the library stores them. The API compiles them against the
robot too; this is the format check every write passes."""

from __future__ import annotations

from backend.engine.library import DocValidator, model_validator_for
from backend.graph.schema import Program, Subgraph


def library_validators() -> dict[str, DocValidator]:
    """Validators for `RobotLibrary(..., validators=...)`: kind -> normalised document or LibraryError."""
    return {
        "programs": model_validator_for(Program, "program"),
        "subgraphs": model_validator_for(Subgraph, "subgraph"),
    }
