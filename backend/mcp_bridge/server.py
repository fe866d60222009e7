"""An MCP server (official `mcp` SDK, low-level `Server`) that offers a running Nutty server's tools.

Nothing here is written per tool: `tools/list` is GET /api/tools (generated from the command registry
and the running robot, program and library) and `tools/call` is POST /api/tools/{name}, so the tools,
their enums and their validation are the server's. A tool call's result says what happened (the
command's id and status, and with `wait` how it ended) as text and as structured content; a refusal
is a tool error naming the field, never a protocol error. Each tool carries MCP annotations chosen by
its declaration (GET /api/tools?format=mcp). A waited long action called with a progress token
reports its progress (backend/mcp_bridge/progress.py). Resources (the robot's embodiment, the running
program, the clip/posture library and the robot's status) can be subscribed to, and the prompt
`robot_brief` describes the robot (backend/mcp_bridge/resources.py).

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
from mcp.server.subscriptions import InMemorySubscriptionBus, ListenHandler, ResourceUpdated, ToolsListChanged
from mcp_types.version import MODERN_PROTOCOL_VERSIONS

from backend import __version__
from backend.mcp_bridge import resources
from backend.mcp_bridge.progress import call_with_progress
from backend.mcp_bridge.remote import Remote

log = logging.getLogger(__name__)
MAX_SESSIONS = 64  # handshake-era connections remembered for list-changed notifications

INSTRUCTIONS = """You drive a Nutty robot (an expressive animated robot). Its tools come from the robot \
itself: play_clip and set_posture offer exactly the moves it has, each described. Long actions answer at once \
with an `id`: pass `wait: true` to answer when they end, poll with get_status(id), or stop them with cancel. \
Several clips on one layer: choose if_busy (replace, queue or reject). The robot's safety limits always hold."""


class Announcer:
    """Tells every connected MCP client that the tool list changed."""

    def __init__(self) -> None:
        self.bus = InMemorySubscriptionBus()  # 2026-era clients: subscriptions/listen streams
        self.subscribers = resources.Subscribers()  # handshake-era resource subscriptions
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

    async def resources_updated(self, uris: tuple[str, ...]) -> None:
        for uri in uris:
            await self.bus.publish(ResourceUpdated(uri=uri))
            await self.subscribers.notify(uri)

    async def tools_changed(self) -> None:
        await self.bus.publish(ToolsListChanged())
        for key, (_, session) in list(self._sessions.items()):
            try:
                await session.send_tool_list_changed()
            except Exception as exc:  # that client is gone (its stream closed, whichever way)
                log.debug("tools-changed not delivered; forgetting that session: %s", exc, exc_info=True)
                self._sessions.pop(key, None)


def _tool_handlers(remote: Remote, announcer: Announcer) -> dict[str, Any]:
    """tools/list and tools/call, answered by the Nutty server."""

    async def list_tools(ctx: Any, params: Any) -> types.ListToolsResult:
        announcer.remember(ctx.session)
        answer = await remote.request("GET", "/api/tools", params={"format": "mcp"})
        if not answer.ok:
            raise RuntimeError(_error_text(answer))
        return types.ListToolsResult(tools=[types.Tool.model_validate(t) for t in answer.body])

    async def call_tool(ctx: Any, params: types.CallToolRequestParams) -> types.CallToolResult:
        announcer.remember(ctx.session)
        arguments = params.arguments or {}
        token = _progress_token(ctx)
        if token is not None and arguments.get("wait") is True:

            async def report(fraction: float, message: str) -> None:
                await ctx.session.send_progress_notification(
                    token, fraction, 1.0, message, related_request_id=ctx.request_id
                )

            answer = await call_with_progress(remote, params.name, arguments, report)
        else:
            answer = await remote.call(params.name, arguments)
        if not answer.ok:
            return types.CallToolResult(
                content=[types.TextContent(text=_error_text(answer))],
                structured_content={"error": answer.body},
                is_error=True,
            )
        return types.CallToolResult(
            content=[types.TextContent(text=summary(answer.body))], structured_content=answer.body
        )

    return {"on_list_tools": list_tools, "on_call_tool": call_tool}


def _resource_handlers(remote: Remote, announcer: Announcer) -> dict[str, Any]:
    """Resources (read, subscribe) and the robot_brief prompt (backend/mcp_bridge/resources.py)."""

    async def list_resources(ctx: Any, params: Any) -> types.ListResourcesResult:
        return types.ListResourcesResult(
            resources=[
                types.Resource(uri=uri, name=name, description=text, mime_type="application/json")
                for uri, name, text, _ in resources.RESOURCES
            ]
        )

    async def read_resource(ctx: Any, params: types.ReadResourceRequestParams) -> types.ReadResourceResult:
        body = await resources.read(remote, str(params.uri))
        return types.ReadResourceResult(
            contents=[
                types.TextResourceContents(
                    uri=str(params.uri), mime_type="application/json", text=json.dumps(body, indent=1)
                )
            ]
        )

    async def subscribe(ctx: Any, params: Any) -> types.EmptyResult:
        uri = str(params.uri)
        if uri not in {r[0] for r in resources.RESOURCES}:
            raise ValueError(f"unknown resource {uri}")
        announcer.subscribers.add(uri, ctx.session)
        return types.EmptyResult()

    async def unsubscribe(ctx: Any, params: Any) -> types.EmptyResult:
        announcer.subscribers.remove(str(params.uri), ctx.session)
        return types.EmptyResult()

    async def list_prompts(ctx: Any, params: Any) -> types.ListPromptsResult:
        return types.ListPromptsResult(
            prompts=[types.Prompt(name=resources.PROMPT, description=resources.PROMPT_DESCRIPTION)]
        )

    async def get_prompt(ctx: Any, params: types.GetPromptRequestParams) -> types.GetPromptResult:
        if params.name != resources.PROMPT:
            raise ValueError(f"unknown prompt {params.name!r} (prompts: ['{resources.PROMPT}'])")
        robot = await resources.read(remote, resources.ROBOT)
        library = await resources.read(remote, resources.LIBRARY)
        text = resources.brief(robot, library)
        return types.GetPromptResult(
            description=resources.PROMPT_DESCRIPTION,
            messages=[types.PromptMessage(role="user", content=types.TextContent(text=text))],
        )

    return {
        "on_list_resources": list_resources,
        "on_read_resource": read_resource,
        "on_subscribe_resource": subscribe,
        "on_unsubscribe_resource": unsubscribe,
        "on_list_prompts": list_prompts,
        "on_get_prompt": get_prompt,
    }


def create_server(remote: Remote) -> tuple[Server, Announcer]:
    """The MCP server for `remote`, and its Announcer (feed it the server's `tools_changed` events)."""
    announcer = Announcer()
    server = Server(
        "nutty",
        version=__version__,
        title="Nutty robot",
        instructions=INSTRUCTIONS,
        on_subscriptions_listen=ListenHandler(announcer.bus),
        **_tool_handlers(remote, announcer),
        **_resource_handlers(remote, announcer),
    )
    return server, announcer


def initialization_options(server: Server) -> Any:
    """What the server declares at the handshake: tools whose list changes, resources."""
    return server.create_initialization_options(NotificationOptions(tools_changed=True))


def _progress_token(ctx: Any) -> Any:
    """The caller's progress token for this request, None when it asked for no progress."""
    meta = getattr(ctx, "meta", None) or {}
    return meta.get("progress_token", meta.get("progressToken")) if isinstance(meta, dict) else None


def summary(body: dict[str, Any]) -> str:
    """One line saying what a tool call did, then its JSON (for a model reading text only)."""
    if body.get("tool") == "get_status":
        head = "status of the robot"
    elif body.get("tool") == "get_frame":
        head = f"the robot's last frame (t {body.get('t')} s)"
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
