"""Scalar state held in a cell of a small array, read and written as a plain attribute.

The compiled program core (backend/engine/core/) steps a block's timers (a breath's phase, a weight
shift's schedule, a blink's clock) in place, so they live in arrays of the block's state; the block's
own Python reads them by name through these properties, and both step the same numbers.
"""

from __future__ import annotations

from typing import Any


def cell(array: str, i: int, doc: str) -> Any:
    """A float property over `self.<array>[i]`."""

    def get(self: Any) -> float:
        return float(getattr(self, array)[i])

    def put(self: Any, value: float) -> None:
        getattr(self, array)[i] = value

    return property(get, put, doc=doc)


def flag(array: str, i: int, doc: str) -> Any:
    """A bool property over `self.<array>[i]` (1.0 true, 0.0 false)."""

    def get(self: Any) -> bool:
        return bool(getattr(self, array)[i] > 0.5)

    def put(self: Any, value: bool) -> None:
        getattr(self, array)[i] = 1.0 if value else 0.0

    return property(get, put, doc=doc)
