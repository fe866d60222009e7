"""Helpers shared by the sub-commands."""

from __future__ import annotations

import sys


def fail(message: str, code: int = 2) -> int:
    """Print an error for a person and return the exit code to use."""
    print(f"nutty: error: {message}", file=sys.stderr)
    return code


def warn_unsafe() -> None:
    """Say loudly that the engine's safety net is off (`--unsafe-no-limits`)."""
    print(
        "nutty: WARNING: --unsafe-no-limits: the engine's safety net is OFF; frames are not limited to the "
        "robot's position, velocity, acceleration or jerk limits",
        file=sys.stderr,
    )
