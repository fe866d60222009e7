"""An MCP server (official `mcp` SDK, low-level `Server`) that offers a running Nutty server's tools.

Nothing here is written per tool: `tools/list` is GET /api/tools (generated from the command registry
and the running robot, program and library) and `tools/call` is POST /api/tools/{name}, so the tools,
their enums and their validation are the server's. A tool call's result says what happened (the
command's id and status, and with `wait` how it ended) as text and as structured content; a refusal
is a tool error naming the field, never a protocol error. Resources: the robot's embodiment, the
running program, the clip/posture library and the robot's status.

When the server announces `tools_changed` on /ws/control (a clip saved, a program loaded), every
connected client is told the tool list changed: handshake-era clients by
`notifications/tools/list_changed`, 2026-era clients on their `subscriptions/listen` stream.
"""

from __future__ import annotations

import json
import logging
from typing import Any

import mcp_types as types
from mcp.server.lowlevel import NotificationOptions, Server
from mcp.server.subscriptions import InMemorySubscriptionBus, ListenHandler, ToolsListChanged
from mcp_types.version import MODERN_PROTOCOL_VERSIONS

from backend import __version__
from backend.mcp_bridge.remote import Remote

log = logging.getLogger(__name__)
MAX_SESSIONS = 64  # handshake-era connections remembered for list-changed notifications

INSTRUCTIONS = """You drive a Nutty robot (an expressive animated robot). Its tools come from the robot \
itself: play_clip and set_posture offer exactly the moves it has, each described. Long actions answer at once \
with an `id`: pass `wait: true` to answer when they end, poll with get_status(id), or stop them with cancel. \
Several clips on one layer: choose if_busy (replace, queue or reject). The robot's safety limits always hold."""

RESOURCES = (  # uri, name, description, server path (None: from the tools' library section)
    (
        "nutty://robot",
        "robot",
        "The robot's embodiment: DoFs with units, limits and descriptions, postures.",
        "/api/robot",
    ),
    (
        "nutty://program",
        "program",
        "The running Animation Program: blocks, wires, exposed inputs, level.",
        "/api/program",
    ),
    (
        "nutty://library",
        "library",
        "The robot's clips (description, duration in s) and postures (description).",
        None,
    ),
    (
        "nutty://status",
        "status",
        "What the robot is doing now: per-layer playback, posture move, gaze, mood, "
        "layer weights and the engine's health.",
        "/api/tools/get_status",
    ),
)


class Announcer:
    """Tells every connected MCP client that the tool list changed."""

    def __init__(self) -> None:
        self.bus = InMemorySubscriptionBus()  # 2026-era clients: subscriptions/listen streams
        self._sessions: dict[
            int, tuple[Any, Any]
        ] = {}  # handshake-era: id(client params) -> (params, session)

    def remember(self, session: Any) -> None:
        """Keep a handshake-era connection's session for later notifications (2026-era ones listen)."""
        params = session.client_params
        if params is None or session.protocol_version in MODERN_PROTOCOL_VERSIONS:
            return
        self._sessions[id(params)] = (params, session)
        while len(self._sessions) > MAX_SESSIONS:
            self._sessions.pop(next(iter(self._sessions)))

    async def tools_changed(self) -> None:
        await self.bus.publish(ToolsListChanged())
        for key, (_, session) in list(self._sessions.items()):
            try:
                await session.send_tool_list_changed()
            except Exception as exc:  # that client is gone (its stream closed, whichever way)
                log.debug("tools-changed not delivered; forgetting that session: %s", exc, exc_info=True)
                self._sessions.pop(key, None)


def create_server(remote: Remote) -> tuple[Server, Announcer]:
    """The MCP server for `remote`, and its Announcer (feed it the server's `tools_changed` events)."""
    announcer = Announcer()

    async def list_tools(ctx: Any, params: Any) -> types.ListToolsResult:
        announcer.remember(ctx.session)
        answer = await remote.tools()
        if not answer.ok:
            raise RuntimeError(_error_text(answer))
        return types.ListToolsResult(
            tools=[
                types.Tool(
                    name=t["name"],
                    description=t["description"],
                    input_schema=t["parameters"],
                    annotations=types.ToolAnnotations(read_only_hint=t["command"] is None),
                )
                for t in answer.body["tools"]
            ]
        )

    async def call_tool(ctx: Any, params: types.CallToolRequestParams) -> types.CallToolResult:
        announcer.remember(ctx.session)
        answer = await remote.call(params.name, params.arguments or {})
        if not answer.ok:
            return types.CallToolResult(
                content=[types.TextContent(text=_error_text(answer))],
                structured_content={"error": answer.body},
                is_error=True,
            )
        return types.CallToolResult(
            content=[types.TextContent(text=summary(answer.body))], structured_content=answer.body
        )

    async def list_resources(ctx: Any, params: Any) -> types.ListResourcesResult:
        return types.ListResourcesResult(
            resources=[
                types.Resource(uri=uri, name=name, description=text, mime_type="application/json")
                for uri, name, text, _ in RESOURCES
            ]
        )

    async def read_resource(ctx: Any, params: types.ReadResourceRequestParams) -> types.ReadResourceResult:
        entry = next((r for r in RESOURCES if r[0] == str(params.uri)), None)
        if entry is None:
            raise ValueError(f"unknown resource {params.uri} (resources: {[r[0] for r in RESOURCES]})")
        path = entry[3]
        answer = await (
            remote.request("POST", path, json={})
            if path and path.startswith("/api/tools/")
            else remote.request("GET", path or "/api/tools")
        )
        if not answer.ok:
            raise RuntimeError(_error_text(answer))
        body = answer.body["library"] if path is None else answer.body
        return types.ReadResourceResult(
            contents=[
                types.TextResourceContents(
                    uri=entry[0], mime_type="application/json", text=json.dumps(body, indent=1)
                )
            ]
        )

    server = Server(
        "nutty",
        version=__version__,
        title="Nutty robot",
        instructions=INSTRUCTIONS,
        on_list_tools=list_tools,
        on_call_tool=call_tool,
        on_list_resources=list_resources,
        on_read_resource=read_resource,
        on_subscriptions_listen=ListenHandler(announcer.bus),
    )
    return server, announcer


def initialization_options(server: Server) -> Any:
    """What the server declares at the handshake: tools whose list changes, resources."""
    return server.create_initialization_options(NotificationOptions(tools_changed=True))


def summary(body: dict[str, Any]) -> str:
    """One line saying what a tool call did, then its JSON (for a model reading text only)."""
    if body.get("tool") == "get_status":
        head = "status of the robot"
    else:
        status = body.get("status")
        head = f"{body.get('tool')}: {status} (command {body.get('command')}, id {body.get('id')})"
        if body.get("timed_out"):
            head += "; still running after the wait's timeout"
        elif status in ("started", "queued"):
            head += "; it runs on: wait with get_status(id, wait=true), or cancel(target=id)"
    return f"{head}\n{json.dumps(body)}"


def _error_text(answer: Any) -> str:
    body = answer.body if isinstance(answer.body, dict) else {"message": str(answer.body)}
    field = f" (field '{body['field']}')" if body.get("field") else ""
    return f"error {body.get('code', answer.status)}{field}: {body.get('message', '')}"
