"""Tools for AIs: the tool definitions generated for the running robot and program, in each
function-calling dialect, and carrying out one tool call (backend.tools).

`tools_changed(hub)` is called by the routes that change the program or the library: when the tools
differ from the last ones announced, every /ws/control client gets
`{"type": "event", "event": "tools_changed", "id": null, "revision", "tools": [names]}`.
"""

from __future__ import annotations

import asyncio
from typing import Any, Literal

from fastapi import APIRouter, Query

from backend.api_types import ToolAnswer, Tools
from backend.hub import Hub
from backend.routes.bodies import ToolArguments
from backend.routes.errors import api_error
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep
from backend.tools import ToolError, build_tools, render
from backend.tools.call import call_tool

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["tools"])


@router.get(
    "/tools",
    response_model=Tools,
    summary="Tool definitions for AIs, generated from the commands and the running robot",
)
async def get_tools(
    hub: HubDep,
    format: Literal["plain", "openai", "anthropic", "gemini", "mcp"] = Query(
        "plain",
        description="plain (nutty-tools/1), openai (function tools), anthropic (Messages `tools`), "
        "gemini (a `tools` entry of function declarations) or mcp (MCP's `tools/list` tools)",
    ),
    strict: bool = Query(
        False,
        description="openai only: OpenAI's strict function calling (closed objects, every property "
        "required, null for an argument not given)",
    ),
    api: Literal["chat", "responses", "realtime"] = Query(
        "chat",
        description="openai only: the tool shape of Chat Completions, the Responses or the Realtime API",
    ),
) -> Any:
    toolset = await asyncio.to_thread(build_tools, hub.session)
    hub.tools_revision = hub.tools_revision or toolset.revision  # what clients now know
    try:
        return render(toolset, format, strict=strict, api=api)
    except ValueError as exc:
        raise api_error(422, "invalid_query", str(exc), field="strict" if strict else "api") from exc


@router.post(
    "/tools/{name}", response_model=ToolAnswer, summary="Carry out one tool call (its arguments as the body)"
)
async def post_tool(name: str, arguments: ToolArguments, hub: HubDep) -> dict[str, Any]:
    try:
        return await call_tool(hub, name, arguments)
    except ToolError as exc:
        raise api_error(
            exc.status, exc.code, str(exc), **({"field": exc.field} if exc.field else {})
        ) from exc


async def tools_changed(hub: Hub) -> None:
    """Announce the tools on /ws/control if they changed since they were last announced or read."""
    toolset = await asyncio.to_thread(build_tools, hub.session)
    if toolset.revision == hub.tools_revision:
        return
    hub.tools_revision = toolset.revision
    hub.broadcast(
        {
            "type": "event",
            "event": "tools_changed",
            "id": None,
            "revision": toolset.revision,
            "tools": [t.name for t in toolset.tools],
        }
    )
