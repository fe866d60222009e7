"""The HTTP and WebSocket API (FastAPI): AIs and the editor drive a running engine through it.

`create_app(session, ...)` builds the app around an EngineSession (tests use it without ports);
`nutty serve` runs it with uvicorn next to the engine clock and the viser Pre-Viz. The contract the
editor relies on is docs/api-contract.md; OpenAPI is served at /docs.

The routes live in `backend.routes`, one router per concern; the server's state (the session, the
command log, connected clients, the event fan-out) is the `Hub` (backend.hub) on `app.state.hub`.

Safety (the rules live in `backend.security`, enforced once by its ASGI `Guard`): mutating routes and
WebSocket handshakes need an allowed Origin (when a browser sends one) and Host, and the token when
there is one; JSON bodies must be declared `application/json`, are counted as they stream in and
parsed with depth, size, NaN/inf and Unicode limits (backend.routes.json_body); a bad request gets a
4xx naming the field and changes nothing; an unexpected error is a JSON 500 without a traceback and
never closes a socket. Every WebSocket handler races its send loop against the client's disconnect
and the app's shutdown, so no thread, sink or client count outlives its client. The Pre-Viz is
proxied at /previz/ behind the same guard and token.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from pathlib import Path
from typing import Any

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

from backend import __version__, security
from backend.engine import clip_preview
from backend.hub import Hub
from backend.routes import (
    analysis,
    behaviours,
    clip_editing,
    commands,
    library,
    program,
    robot,
    sockets,
    sounds,
    status,
    tools,
)
from backend.routes.errors import SafeJSONResponse, install_error_handlers
from backend.routes.sounds import SOUND_BODY
from backend.security import MAX_BODY
from backend.session import EngineSession

FRONTEND_DIST = Path(__file__).resolve().parents[1] / "frontend" / "dist"
log = logging.getLogger(__name__)

ROUTERS = (
    robot.router,
    program.router,
    library.router,
    commands.router,
    tools.router,
    status.router,
    status.previz_proxy,
    sockets.router,
    analysis.router,
    clip_editing.router,
    sounds.router,
    behaviours.router,
)


def create_app(
    session: EngineSession,
    *,
    token: str | None = None,
    previz: Any = None,
    allowed_origins: list[str] | None = None,
    port: int | None = None,
    host: str = "127.0.0.1",
    origins: list[str] | None = None,
    frontend_dir: Path | None = FRONTEND_DIST,
) -> FastAPI:
    """The API around `session`.

    `allowed_origins`: origins besides the server's own (http://localhost|127.0.0.1|[::1]:`port`, and
    `host` when it is a specific address) that may change the robot from a browser; they also get
    CORS. `port` None (tests, embedding) accepts any port. `origins` is the old name of
    `allowed_origins`. Raises ValueError for a malformed origin.
    """
    extra_origins = [*(allowed_origins or []), *(origins or [])]
    policy = security.AccessPolicy(token=token, port=port, bind_host=host, allowed_origins=extra_origins)
    hub = Hub(session, token, previz)
    if previz is not None:  # gizmo drags are commands like REST's: validated, logged, evented
        previz.run_command = hub.run_command

    @contextlib.asynccontextmanager
    async def lifespan(_: FastAPI):
        hub.loop = asyncio.get_running_loop()
        hub.stopping = asyncio.Event()
        # the first ghost / Check limits must not wait for the filter's kernels to compile
        warming = hub.loop.run_in_executor(None, _warm_previews, session)
        try:
            yield
        finally:
            hub.stopping.set()
            warming.cancel()

    app = FastAPI(
        title="Nutty",
        version=__version__,
        lifespan=lifespan,
        default_response_class=SafeJSONResponse,
        description="Robot animation engine: Animation Programs, commands, telemetry and frames.",
    )
    app.state.hub = hub
    app.state.policy = policy
    if extra_origins:
        app.add_middleware(
            CORSMiddleware, allow_origins=extra_origins, allow_methods=["*"], allow_headers=["*"]
        )
    app.add_middleware(
        security.Guard, policy=policy, max_body=MAX_BODY, body_limits=[("/api/sounds", SOUND_BODY)]
    )
    install_error_handlers(app)
    for router in ROUTERS:
        app.include_router(router)
    _serve_editor(app, hub, frontend_dir)
    return app


def _warm_previews(session: EngineSession) -> None:
    """Compile the ghost's and the check's kernels off the event loop; a failure is logged, not raised
    (the routes then compile on their first request)."""
    try:
        took = clip_preview.warm_up(session.embodiment, session.engine.rate)
        log.debug("ghost and Check limits ready in %.2f s", took)
    except Exception:  # a warm-up must never stop the server (logged with its traceback)
        log.exception("warming the ghost and Check limits failed; they compile on first use")


def _serve_editor(app: FastAPI, hub: Hub, frontend_dir: Path | None) -> None:
    """The editor at / (frontend/dist), or a page saying it is not built. Mounted last: it takes every path."""
    if frontend_dir is not None and (frontend_dir / "index.html").exists():
        app.mount("/", StaticFiles(directory=str(frontend_dir), html=True), name="editor")
        return

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def index() -> str:
        session = hub.session
        link = '<li><a href="/previz/">3D Pre-Viz</a></li>' if hub.previz else ""
        return (
            f"<!doctype html><title>Nutty</title><h1>Nutty is running</h1>"
            f"<p>Robot <b>{session.embodiment.name}</b>, program <b>{session.program.name if session.program else '-'}</b>."
            f" The editor is not built (run <code>make run</code>).</p>"
            f"<ul><li><a href='/docs'>API (OpenAPI)</a></li>{link}</ul>"
        )
