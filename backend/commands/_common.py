"""Helpers shared by the sub-commands."""

from __future__ import annotations

import sys


def fail(message: str, code: int = 2) -> int:
    """Print an error for a person and return the exit code to use."""
    print(f"nutty: error: {message}", file=sys.stderr)
    return code
