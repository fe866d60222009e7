"""What the browser's clip editor needs beside the library: a preview pose on the Pre-Viz (the robot
does not move) and recorded takes (the robot's live motion, reduced to a clip and saved)."""

from __future__ import annotations

import asyncio
import time
from typing import Any, Literal

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from backend.api_types import PreviewShown, PreviewState, TakeSaved, TakeStatus
from backend.engine import clip_preview
from backend.engine.library import LibraryError
from backend.errors import DomainError
from backend.hub import Hub
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep
from backend.routes.tools import tools_changed
from backend.take_recorder import TakeRecorder

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["clip editor"])


class PreviewBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    values: dict[str, Any] | None = Field(
        ...,
        description="DoF -> value (rad or m, [r, g, b] in 0..1, an option name) to show; null: stop showing",
    )
    label: str = Field(default="", max_length=120, description="what the Pre-Viz labels the preview with")


class TakeStart(BaseModel):
    model_config = ConfigDict(extra="forbid")
    dofs: list[str] = Field(..., min_length=1, max_length=64, description="continuous DoFs to record")
    source: Literal["output", "program", "stage1"] = Field(
        default="output",
        description="output: what the motors get (after stage 2 and the safety net); program: the "
        "program's frame before the safety net; stage1: the program's pose before stage 2",
    )


class TakeStop(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(..., min_length=1, max_length=80, description="the clip's name in the library")
    tolerance: float = Field(
        default=0.005, ge=0.0, le=0.5, description="key reduction: largest deviation allowed (rad or m)"
    )


@router.put("/previz/preview", response_model=PreviewShown, summary="Show a preview pose on the Pre-Viz")
def put_preview(body: PreviewBody, hub: HubDep) -> dict[str, Any]:
    """The pose shows on the Pre-Viz's solid robot for 3 s (send it again to keep it); the robot
    itself is not moved. `values: null` stops the preview at once."""
    return hub.pose_preview.show(body.values, body.label)


@router.get(
    "/previz/preview",
    response_model=PreviewState,
    summary="The preview pose and the DoFs turned in the Pre-Viz",
)
def get_preview(hub: HubDep) -> dict[str, Any]:
    return hub.pose_preview.state()


def _status(hub: Hub, take: TakeRecorder | None) -> dict[str, Any]:
    if take is None:
        return {
            "recording": False,
            "dofs": [],
            "source": "",
            "rate": hub.session.engine.rate,
            "samples": 0,
            "elapsed": 0.0,
        }
    return {
        "recording": hub.take is take,
        "dofs": take.dofs,
        "source": take.source,
        "rate": hub.session.engine.rate,
        "samples": take.samples,
        "elapsed": take.elapsed,
    }


@router.post("/record/start", response_model=TakeStatus, summary="Start recording a take of chosen DoFs")
def start_take(body: TakeStart, hub: HubDep) -> dict[str, Any]:
    if hub.take is not None:
        raise DomainError(
            f"a take of {', '.join(hub.take.dofs)} is being recorded (for {time.time() - hub.take.started_at:.0f} s):"
            " stop it first",
            code="recording",
        )
    hub.take = TakeRecorder(hub.session.embodiment, body.dofs, body.source)
    hub.session.engine.add_sink(hub.take)
    return _status(hub, hub.take)


@router.get("/record", response_model=TakeStatus, summary="The take being recorded")
def take_status(hub: HubDep) -> dict[str, Any]:
    return _status(hub, hub.take)


def _end_take(hub: Hub) -> TakeRecorder:
    take = hub.take
    if take is None:
        raise DomainError("no take is being recorded: POST /api/record/start first", code="not_recording")
    hub.take = None
    hub.session.engine.remove_sink(take)
    return take


@router.delete("/record", response_model=TakeStatus, summary="Discard the take being recorded")
def cancel_take(hub: HubDep) -> dict[str, Any]:
    take = _end_take(hub)
    return {**_status(hub, take), "recording": False}


@router.post(
    "/record/stop",
    response_model=TakeSaved,
    summary="Stop recording: the take as a clip, saved in the library",
)
async def stop_take(body: TakeStop, hub: HubDep) -> dict[str, Any]:
    """The take's samples become keys (a smooth curve within `tolerance`), saved as clip `name`, with
    the trajectory-helper's report on it. A bad name leaves the take recording, so nothing is lost."""
    session = hub.session
    try:
        session.library.check_name(body.name)
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_name", field="name") from exc
    take = _end_take(hub)
    result = await asyncio.to_thread(take.finish, body.name, body.tolerance, session.embodiment.name)
    try:
        stored = await asyncio.to_thread(session.library.save, "clips", body.name, result["clip"])
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_document", field=exc.field) from exc
    await tools_changed(hub)
    report = await asyncio.to_thread(
        clip_preview.analyze_clip, session.embodiment, session.engine.rate, stored, session.engine.rate
    )
    warnings = await asyncio.to_thread(session.library.joint_warnings, "clips", stored)
    return {**result, "saved": body.name, "clip": stored, "report": report, "warnings": warnings}
