"""The trajectory-helper and the ghost for a DCC tool (the Blender add-on): it sends its animation and
gets back where it breaks the robot's limits (POST /api/analyze) or what the motion filter makes of it
(POST /api/filter). Nothing here changes the robot or the running program.

Two bodies: a `clip` (the nutty-clip/1 document the tool would export) is judged and filtered at the
engine's rate by the playback code and answered at the scene's frames (backend/engine/clip_preview.py),
so the ghost and the check agree with what the robot plays; `tracks` (values already sampled at
`rate`) are judged and filtered at that rate, as older add-ons expect.
"""

from __future__ import annotations

import asyncio
from typing import Any, Literal

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field, model_validator

from backend.api_types import FilteredTracks, TrackAnalysis
from backend.control.targets import blocks_of
from backend.engine import clip_preview
from backend.engine.blocks.motion_filter import FilterParams
from backend.engine.track_analysis import (
    TrackError,
    analyze_tracks,
    filter_tracks,
)
from backend.errors import DomainError
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import SessionDep

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["analysis"])


class TracksBody(BaseModel):
    """A clip, or sampled tracks (continuous DoF -> values (rad or m) at `rate` Hz, all the same length):
    exactly one of the two."""

    model_config = ConfigDict(extra="forbid")
    rate: float = Field(
        ...,
        ge=1.0,
        le=10000.0,
        description="samples per second (Hz): the scene's fps; for a clip the rate of the answer's samples",
    )
    tracks: dict[str, list[float]] | None = Field(
        default=None, min_length=1, description="DoF name -> one value per sample"
    )
    clip: dict[str, Any] | None = Field(
        default=None, description="a nutty-clip/1 document (clip time 0 = the scene's first frame)"
    )

    @model_validator(mode="after")
    def _one_source(self) -> TracksBody:
        if (self.tracks is None) == (self.clip is None):
            raise ValueError("send either `clip` (a nutty-clip/1 document) or `tracks`, not both or neither")
        return self


class AnalyzeBody(TracksBody):
    fit: bool = Field(
        default=True,
        description="clips: also search the slow-down that fits (`fit_scale`, `suggestion`); false answers "
        "the ranges alone, several times faster",
    )
    physics: bool = Field(
        default=False,
        description="clips: also play the clip in MuJoCo through the running program and answer what the "
        "motors make of it, raw and filtered (`physics`: tracking error, effort, contacts; "
        "docs/simulation.md). Needs the `sim` extra",
    )


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
async def analyze(body: AnalyzeBody, session: SessionDep) -> dict[str, Any]:
    """Per DoF, ranges of samples over the velocity (orange), acceleration (pink) or jerk (red) limit,
    or outside the position limits, each with its worst ratio to the limit; a clip also gets the
    slow-down that fits. See backend/engine/clip_preview.py and track_analysis.py."""
    if body.physics and body.clip is None:
        raise DomainError(
            "`physics` needs a clip: send `clip`, not `tracks`", code="invalid", field="physics"
        )
    try:
        if body.clip is None:
            return await asyncio.to_thread(analyze_tracks, session.embodiment, body.rate, body.tracks or {})
        answer = await asyncio.to_thread(
            clip_preview.analyze_clip,
            session.embodiment,
            session.engine.rate,
            body.clip,
            body.rate,
            body.fit,
        )
    except TrackError as exc:
        raise _track_error(exc) from exc
    if body.physics:
        answer["physics"] = await asyncio.to_thread(_clip_physics, session, body.clip)
    return answer


def _clip_physics(session: Any, clip: dict[str, Any]) -> dict[str, Any]:
    """The clip in MuJoCo through the running program (backend/sim/analysis.py); a DomainError when
    MuJoCo is missing or cannot model the robot."""
    from backend.sim.analysis import clip_physics  # lazy: MuJoCo is an optional extra
    from backend.sim.availability import SimUnavailable
    from backend.sim.model import SimError
    from backend.sim.motions import MotionError

    program = session.program.to_json_dict() if session.program is not None else None
    try:
        return clip_physics(session.embodiment, clip, program, session.engine.rate, session.engine.sinks)
    except SimUnavailable as exc:
        raise DomainError(str(exc), code="sim_unavailable", field="physics") from exc
    except (SimError, MotionError) as exc:
        raise DomainError(f"physics: {exc}", code="invalid", field="physics") from exc


@router.post(
    "/filter",
    response_model=FilteredTracks,
    summary="Ghost: a clip or posted tracks through the motion filter (a preset or the program's stage 2)",
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
        if body.clip is not None:
            rate, tracks = await asyncio.to_thread(
                clip_preview.filter_clip,
                session.embodiment,
                session.engine.rate,
                body.clip,
                body.rate,
                params,
            )
        else:
            rate = body.rate
            tracks = await asyncio.to_thread(
                filter_tracks, session.embodiment, body.rate, body.tracks or {}, params
            )
    except TrackError as exc:
        raise _track_error(exc) from exc
    return {
        "rate": body.rate,
        "engine_rate": rate,
        "preset": used,
        "params": params.model_dump(mode="json"),
        "tracks": tracks,
    }
