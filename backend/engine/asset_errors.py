"""Errors of the robot's asset library (clips, postures, programs, subgraphs).

Kept apart from `backend.engine.library` so the document validators the library calls (clips, and the
graph's programs) can raise them without importing the library itself.
"""

from __future__ import annotations


class LibraryError(ValueError):
    """A bad name, a missing asset, or an asset that fails validation; the message says which, and
    `field` (a dotted path such as `tracks.head_pitch.2.t`) where in the document, when known."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


class NotFound(LibraryError):
    """No asset of that kind and name."""
