"""`nutty mcp`: a running Nutty server's tools, offered to AIs over the Model Context Protocol (stdio,
or streamable HTTP), built on the official `mcp` SDK. See docs/ai.md.

    run(Remote("http://127.0.0.1:8000"))             # stdio
    run(Remote("http://127.0.0.1:8000"), http=8765)  # http://127.0.0.1:8765/mcp
"""

from __future__ import annotations

from typing import Any

from backend.mcp_bridge.remote import Remote
from backend.mcp_bridge.resources import updated_by
from backend.mcp_bridge.server import create_server, initialization_options
from backend.mcp_bridge.token import TokenGuard

MCP_PATH = "/mcp"  # where the streamable HTTP transport answers
CHANGE_EVENTS = ("tools_changed", "reconnected")  # /ws/control events after which the tools may differ


async def run(remote: Remote, http: int | None = None, host: str = "127.0.0.1") -> None:
    """Serve MCP for `remote` until stdin closes (stdio) or the process is interrupted (`http` PORT),
    while /ws/control is watched for tool changes."""
    import anyio  # on demand: only the transport in use

    server, announcer = create_server(remote)

    async def on_event(message: dict[str, Any]) -> None:
        if message.get("event") in CHANGE_EVENTS:
            await announcer.tools_changed()
        await announcer.resources_updated(updated_by(message))

    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(remote.watch, on_event)
            if http is None:
                from backend.mcp_bridge.stdio import safe_stdio_server  # only over stdio

                async with safe_stdio_server() as (read, write):
                    await server.run(read, write, initialization_options(server))
            else:
                import uvicorn  # only with --http

                app = server.streamable_http_app(streamable_http_path=MCP_PATH, host=host)
                if remote.token:  # the robot's token guards its MCP endpoint too
                    app = TokenGuard(app, remote.token)
                # log_config=None: uvicorn's records go through the root logger, to stderr at the level
                # `nutty mcp --log-level` set (backend/logs.py), never to stdout
                config = uvicorn.Config(app, host=host, port=http, log_config=None)
                await uvicorn.Server(config).serve()
            tg.cancel_scope.cancel()
    finally:
        await remote.close()


__all__ = ["MCP_PATH", "Remote", "create_server", "run"]
