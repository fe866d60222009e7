"""The trajectory-helper and the ghost for posted tracks: a DCC tool (the Blender add-on) sends its
sampled animation and gets back where it breaks the robot's limits (POST /api/analyze) or what the
motion filter makes of it (POST /api/filter). Nothing here changes the robot or the running program.
"""

from __future__ import annotations

import asyncio
from typing import Any, Literal

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from backend.api_types import FilteredTracks, TrackAnalysis
from backend.control.targets import blocks_of
from backend.engine.blocks.motion_filter import FilterParams
from backend.engine.track_analysis import TrackError, analyze_tracks, filter_tracks
from backend.errors import DomainError
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import SessionDep

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["analysis"])


class TracksBody(BaseModel):
    """Sampled tracks: continuous DoF -> values (rad or m) at `rate` Hz, all the same length."""

    model_config = ConfigDict(extra="forbid")
    rate: float = Field(..., ge=1.0, le=10000.0, description="samples per second (Hz), e.g. the scene's fps")
    tracks: dict[str, list[float]] = Field(..., min_length=1, description="DoF name -> one value per sample")


class FilterBody(TracksBody):
    preset: Literal["W", "A", "B", "C", "D", "E"] | None = Field(
        default=None,
        description="one of the paper's NMF presets; omitted: the running program's stage-2 filter",
    )


def _track_error(exc: TrackError) -> DomainError:
    return DomainError(str(exc), code="invalid_track", field=exc.field)


@router.post(
    "/analyze",
    response_model=TrackAnalysis,
    summary="Trajectory-helper: where posted tracks break the robot's limits",
)
async def analyze(body: TracksBody, session: SessionDep) -> dict[str, Any]:
    """Per DoF, ranges of samples over the velocity (orange), acceleration (pink) or jerk (red) limit,
    or outside the position limits, each with its worst ratio to the limit; see
    backend/engine/track_analysis.py."""
    try:
        return await asyncio.to_thread(analyze_tracks, session.embodiment, body.rate, body.tracks)
    except TrackError as exc:
        raise _track_error(exc) from exc


@router.post(
    "/filter",
    response_model=FilteredTracks,
    summary="Ghost: posted tracks through the motion filter (a preset or the program's stage 2)",
)
async def filter_route(body: FilterBody, session: SessionDep) -> dict[str, Any]:
    if body.preset is not None:
        params, used = FilterParams(preset=body.preset), body.preset
    else:
        stage2 = blocks_of(session, ("nmf_stage2",))
        if not stage2:
            raise DomainError(
                "the running program has no stage-2 motion filter (nmf_stage2): "
                "name a preset (W, A, B, C, D or E)",
                code="no_stage2",
                field="preset",
            )
        params, used = stage2[0].params, "program"
    try:
        tracks = await asyncio.to_thread(filter_tracks, session.embodiment, body.rate, body.tracks, params)
    except TrackError as exc:
        raise _track_error(exc) from exc
    return {"rate": body.rate, "preset": used, "params": params.model_dump(mode="json"), "tracks": tracks}
