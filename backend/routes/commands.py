"""Driving the running program: its exposed inputs, and commands (run, status, cancel).

Commands from here and from /ws/control share one path (`Hub.run_command`): the same validation,
the same log, the same events.
"""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter

from backend import control
from backend.routes.bodies import CommandDoc, InputValue
from backend.routes.errors import api_error
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.telemetry import signal_json

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["commands"])


@router.get("/inputs", summary="Exposed inputs of the running program: values and declarations")
def get_inputs(session: SessionDep) -> dict[str, Any]:
    decls = [i.model_dump() for i in session.program.inputs] if session.program else []
    return {
        "values": {k: signal_json(session.embodiment, v) for k, v in session.inputs().items()},
        "declarations": decls,
    }


@router.put("/inputs/{name}", summary="Set one exposed input")
async def put_input(name: str, body: InputValue, session: SessionDep) -> dict[str, Any]:
    try:
        command = control.parse_command({"type": "set_input", "name": name, "value": body.value})
        result = await asyncio.to_thread(control.execute, session, command)
    except control.CommandError as exc:
        raise api_error(422, "invalid_input", str(exc), field=name) from exc
    return {"name": name, "value": result[name]}


@router.post("/commands", summary="Run a command (one typed union; see /api/schema/commands)")
async def post_command(command: CommandDoc, hub: HubDep) -> dict[str, Any]:
    return await asyncio.to_thread(hub.run_command, command)


@router.get("/commands/{cid}", summary="A command's status")
def get_command(cid: str, hub: HubDep) -> dict[str, Any]:
    entry = hub.commands.get(cid)
    if entry is None:
        raise api_error(404, "unknown_command", f"no command with id '{cid}'")
    return entry


@router.delete("/commands/{cid}", summary="Cancel a long action")
async def cancel_command(cid: str, hub: HubDep) -> dict[str, Any]:
    return await asyncio.to_thread(hub.cancel, cid)
