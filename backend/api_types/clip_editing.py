"""The clip editor's answers: the Pre-Viz preview pose and recorded takes."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from backend.api_types.base import Shape
from backend.api_types.server import TrackAnalysis


class PreviewShown(Shape):
    """PUT /api/previz/preview."""

    preview: bool = Field(..., description="the Pre-Viz shows the pose (false: no Pre-Viz, or cleared)")
    expires_in: float = Field(..., description="s until the preview lapses unless sent again")


class PreviewState(Shape):
    """GET /api/previz/preview: the preview pose and the DoFs turned in the Pre-Viz."""

    active: bool
    label: str
    values: dict[str, Any] = Field(..., description="DoF -> value of the pose shown")
    grabbed: dict[str, float] = Field(..., description="DoF -> value (rad or m) set by turning a link")
    revision: int = Field(..., description="counts the turns: a change means new `grabbed` values")


class TakeStatus(Shape):
    """POST /api/record/start and GET /api/record: the take being recorded."""

    recording: bool
    dofs: list[str]
    source: str
    rate: float = Field(..., description="the engine's rate (Hz): one sample per frame")
    samples: int
    elapsed: float = Field(..., description="frame time recorded so far (s)")


class TakeSaved(Shape):
    """POST /api/record/stop: the take as a clip, saved in the library."""

    saved: str
    clip: dict[str, Any] = Field(..., description="the nutty-clip/1 document saved")
    samples: int
    keys: dict[str, int] = Field(..., description="DoF -> keys kept by the key reduction")
    duration: float = Field(..., description="s")
    max_error: float = Field(..., description="the clip against the recorded samples (rad or m)")
    dropped: int = Field(..., description="frames the recorder missed (it was behind)")
    report: TrackAnalysis
    warnings: list[str] = Field(default_factory=list)
