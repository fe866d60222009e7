"""Driving the running program: its exposed inputs, and commands (run, status, cancel).

Commands from here and from /ws/control share one path (`Hub.run_command`): the same validation,
the same log, the same events.
"""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter

from backend import control
from backend.api_types import CommandAccepted, CommandCancelled, CommandEntry, ExposedInputs, InputSet
from backend.errors import DomainError
from backend.routes.bodies import CommandDoc, InputValue
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.telemetry import signal_json

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["commands"])


@router.get(
    "/inputs",
    response_model=ExposedInputs,
    summary="Exposed inputs of the running program: values and declarations",
)
def get_inputs(session: SessionDep) -> dict[str, Any]:
    decls = [i.model_dump() for i in session.program.inputs] if session.program else []
    return {
        "values": {k: signal_json(session.embodiment, v) for k, v in session.inputs().items()},
        "declarations": decls,
    }


@router.put("/inputs/{name}", response_model=InputSet, summary="Set one exposed input")
async def put_input(name: str, body: InputValue, session: SessionDep) -> dict[str, Any]:
    try:
        command = control.parse_command({"type": "set_input", "name": name, "value": body.value})
        result = await asyncio.to_thread(control.execute, session, command)
    except control.CommandError as exc:
        raise DomainError(str(exc), code="invalid_input", field=name) from exc
    return {"name": name, "value": result[name]}


@router.post(
    "/commands",
    response_model=CommandAccepted,
    summary="Run a command (one typed union; see /api/schema/commands)",
)
async def post_command(command: CommandDoc, hub: HubDep) -> dict[str, Any]:
    return await asyncio.to_thread(hub.run_command, command)


@router.get("/commands/{cid}", response_model=CommandEntry, summary="A command's status")
def get_command(cid: str, hub: HubDep) -> dict[str, Any]:
    entry = hub.commands.get(cid)
    if entry is None:
        raise DomainError(f"no command with id '{cid}'", code="unknown_command")
    return entry


@router.delete("/commands/{cid}", response_model=CommandCancelled, summary="Cancel a long action")
async def cancel_command(cid: str, hub: HubDep) -> dict[str, Any]:
    return await asyncio.to_thread(hub.cancel, cid)
