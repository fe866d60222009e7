"""The robot's behaviours (`robots/<robot>/behaviours/<name>.json`): list with what they take, read,
save (checked item by item), delete, plan (every item's time) and render (played offline through the
running program, for the editor's preview). Playing one on the robot is the `play_behaviour` command.
"""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter

from backend.api_types import (
    BehaviourPlanned,
    BehaviourRendered,
    BehaviourSummary,
    Deleted,
    Saved,
    StoredBehaviour,
)
from backend.behaviours import BehaviourInvalid, parse, plan, vocabulary_of
from backend.behaviours.items import preflight
from backend.behaviours.render import render
from backend.engine.library import LibraryError, NotFound
from backend.errors import DomainError
from backend.routes.bodies import BehaviourDoc, BehaviourRequest
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.tools import tools_changed

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["behaviours"])


def _stored(session: Any, name: str) -> dict[str, Any]:
    try:
        return session.library.get("behaviours", name)
    except NotFound as exc:
        raise DomainError(str(exc), code="not_found") from exc
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_name") from exc


def _check(session: Any, doc: Any, params: Any, strict: bool) -> tuple[Any, list[Any], list[Any]]:
    """(plan or None, errors of the document, what keeps the running program from playing it)."""
    beh, issues = parse(doc)
    if beh is None:
        return None, issues, []
    planned, issues = plan(beh, params, vocabulary_of(session), strict=strict)
    return planned, issues, (preflight(session, planned) if not issues else [])


@router.get("/behaviours", response_model=list[BehaviourSummary], summary="The robot's behaviours")
def list_behaviours(session: SessionDep) -> list[dict[str, Any]]:
    out = []
    for name in session.library.list("behaviours"):
        try:
            doc = session.library.get("behaviours", name)
        except LibraryError as exc:
            out.append(
                {
                    "name": name,
                    "description": "",
                    "params": {},
                    "duration": None,
                    "errors": [{"message": str(exc)}],
                }
            )
            continue
        planned, issues, missing = _check(session, doc, None, strict=False)
        beh = planned.behaviour if planned is not None else None
        out.append(
            {
                "name": name,
                "description": beh.description if beh else str(doc.get("description", "")),
                "params": {k: p.model_dump(exclude_none=True) for k, p in beh.params.items()} if beh else {},
                "duration": round(planned.duration, 4) if planned is not None and not issues else None,
                "errors": [i.to_dict() for i in issues + missing],
            }
        )
    return out


@router.get("/behaviours/{name}", response_model=StoredBehaviour, summary="One of the robot's behaviours")
def get_behaviour(name: str, session: SessionDep) -> dict[str, Any]:
    return _stored(session, name)


@router.put(
    "/behaviours/{name}",
    response_model=Saved,
    summary="Save a behaviour (every error on its item and field: 422 invalid_behaviour)",
)
async def put_behaviour(name: str, doc: BehaviourDoc, session: SessionDep, hub: HubDep) -> dict[str, Any]:
    try:
        session.library.check_name(name)
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_name") from exc
    if not isinstance(doc, dict):
        raise DomainError("a behaviour is a JSON object", code="invalid_document")
    _, issues, missing = await asyncio.to_thread(_check, session, doc, None, False)
    if issues:
        raise BehaviourInvalid(issues, f"behaviour '{name}'")
    stored = {**doc, "name": name}
    try:
        await asyncio.to_thread(session.library.save, "behaviours", name, stored)
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_document", field=exc.field) from exc
    await tools_changed(hub)  # the play_behaviour tool's list of behaviours
    warnings = [f"the running program cannot play it yet: {i.render()}" for i in missing]
    return {"saved": name, "warnings": warnings} if warnings else {"saved": name}


@router.delete("/behaviours/{name}", response_model=Deleted, summary="Delete one of the robot's behaviours")
async def delete_behaviour(name: str, session: SessionDep, hub: HubDep) -> dict[str, Any]:
    try:
        await asyncio.to_thread(session.library.delete, "behaviours", name)
    except NotFound as exc:
        raise DomainError(str(exc), code="not_found") from exc
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_name") from exc
    await tools_changed(hub)
    return {"deleted": name}


def _document(session: Any, body: BehaviourRequest) -> tuple[str, Any]:
    if body.document is not None:
        return body.behaviour or "unsaved", body.document
    if not body.behaviour:
        raise DomainError(
            "give `behaviour` (a stored one's name) or `document`", code="invalid_body", field="behaviour"
        )
    return body.behaviour, _stored(session, body.behaviour)


@router.post(
    "/behaviours/plan",
    response_model=BehaviourPlanned,
    summary="Every item's start and end (s), or every error on its item: what the editor draws",
)
async def plan_behaviour(body: BehaviourRequest, session: SessionDep) -> dict[str, Any]:
    _, doc = _document(session, body)
    planned, issues, missing = await asyncio.to_thread(_check, session, doc, body.params, False)
    errors = [i.to_dict() for i in issues + missing]
    if planned is None:
        return {"valid": False, "duration": 0.0, "params": {}, "items": [], "errors": errors}
    return {**planned.to_dict(), "valid": not errors, "errors": errors}


@router.post(
    "/behaviours/render",
    response_model=BehaviourRendered,
    summary="Play a behaviour offline through the running program: frames and events for a preview",
)
async def render_behaviour(body: BehaviourRequest, session: SessionDep) -> dict[str, Any]:
    name, doc = _document(session, body)
    planned, issues, missing = await asyncio.to_thread(_check, session, doc, body.params, True)
    if issues or missing or planned is None:
        raise BehaviourInvalid(issues + missing, f"behaviour '{name}'")
    return await asyncio.to_thread(render, session, planned, name, body.rate)
