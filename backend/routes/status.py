"""How the server is doing, and the 3D Pre-Viz: status, where the Pre-Viz is, the ghost toggle, and
the Pre-Viz itself proxied at /previz/ behind the same guard and token as the API."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, WebSocket
from fastapi.responses import RedirectResponse, Response

from backend import security
from backend.api_types import GhostSet, PrevizInfo, Profile, ServerStatus, ThemeSet
from backend.drivers.readings import hardware_status, joint_readings, simulation_status
from backend.errors import DomainError
from backend.hub import Hub
from backend.routes.bodies import GhostToggle, ThemeChoice
from backend.routes.errors import api_error
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["status"])
previz_proxy = APIRouter(include_in_schema=False)


def _previz_urls(hub: Hub, request: Request) -> dict[str, Any]:
    base = str(request.base_url).rstrip("/")
    # With a token nothing but the proxy serves the Pre-Viz: no direct port to advertise.
    direct = None if hub.token is not None else hub.previz.url("127.0.0.1")
    return {"url": f"{base}/previz/", "direct": direct, "token_required": hub.token is not None}


def _no_previz() -> DomainError:
    return DomainError("this server runs without a Pre-Viz", code="no_previz")


@router.get(
    "/status",
    response_model=ServerStatus,
    summary="Tick statistics, APU level, drivers with drop counts, clients",
)
def status(request: Request, hub: HubDep) -> dict[str, Any]:
    session = hub.session
    stats = session.engine.stats()
    stats["clients"] = dict(hub.clients)
    stats["program"] = session.program.name if session.program else None
    stats["previz"] = (
        {
            **_previz_urls(hub, request),
            "frames_shown": hub.previz.frames_shown,
            "ghost": hub.previz.ghost_visible,
        }
        if hub.previz
        else None
    )
    sinks = session.engine.sinks
    stats["joints"] = joint_readings(sinks)
    stats["hardware"] = hardware_status(sinks)
    stats["simulation"] = simulation_status(sinks)
    return stats


@router.get(
    "/profile",
    response_model=Profile,
    summary="Per-node cook times of the running program (µs, sampled ticks)",
)
def profile(hub: HubDep) -> dict[str, Any]:
    return hub.session.engine.profile()


@router.delete(
    "/profile",
    response_model=Profile,
    summary="Start a new measurement window (cook times, tick cost, period, jitter)",
)
def reset_profile(hub: HubDep) -> dict[str, Any]:
    engine = hub.session.engine
    engine.call(engine.reset_stats)
    return engine.profile()


@router.get(
    "/previz",
    response_model=PrevizInfo,
    summary="Where the 3D Pre-Viz is served (the URL a client should open)",
)
def previz_info(request: Request, hub: HubDep) -> dict[str, Any]:
    if hub.previz is None:
        return {"url": None, "direct": None, "token_required": hub.token is not None, "ghost": None}
    return {**_previz_urls(hub, request), "ghost": hub.previz.ghost_visible}


@router.put("/previz/ghost", response_model=GhostSet, summary="Show or hide the ghost (stage-1 pose)")
async def previz_ghost(body: GhostToggle, hub: HubDep) -> dict[str, Any]:
    if hub.previz is None:
        raise _no_previz()
    hub.previz.set_ghost(body.visible)
    return {"ghost": body.visible}


@router.put("/previz/theme", response_model=ThemeSet, summary="Light or dark Pre-Viz, as the editor's theme")
async def previz_theme(body: ThemeChoice, hub: HubDep) -> dict[str, Any]:
    if hub.previz is None:
        raise _no_previz()
    hub.previz.set_theme(body.theme)
    return {"theme": body.theme}


@previz_proxy.get("/previz")
def previz_redirect(request: Request) -> Response:
    query = request.url.query
    return RedirectResponse(f"/previz/{'?' + query if query else ''}", status_code=307)


@previz_proxy.get("/previz/{path:path}")
async def previz_page(path: str, request: Request, hub: HubDep) -> Response:
    if hub.previz is None:
        raise _no_previz()
    from backend.previz import embed_page, fetch_page  # a server without a Pre-Viz never loads it

    # `?embed=1` (the editor's pane): the page without viser's control panel and notifications
    embed = path in ("", "index.html") and request.query_params.get("embed") not in (None, "", "0")
    try:
        status_code, headers, body = await fetch_page(
            hub.previz.port, path, "" if embed else request.headers.get("accept-encoding", "")
        )
    except Exception as exc:  # refused, reset, truncated, timed out, malformed: the same to the client
        raise api_error(
            502, "previz_unavailable", f"the Pre-Viz did not answer: {type(exc).__name__}"
        ) from exc
    if embed and status_code == 200 and headers.get("content-encoding", "identity") == "identity":
        body = embed_page(body)
    response = Response(body, status_code=status_code, headers=headers)
    if hub.token is not None:  # the page's WebSocket (same path, no query) then carries the cookie
        response.set_cookie(
            security.PREVIZ_COOKIE,
            security.previz_cookie_value(hub.token),
            path="/previz",
            httponly=True,
            samesite="strict",
        )
    return response


async def previz_socket(ws: WebSocket, hub: HubDep) -> None:
    if hub.previz is None:
        await ws.close(code=4404, reason="this server runs without a Pre-Viz")
        return
    from backend.previz import relay_socket  # a server without a Pre-Viz never loads it

    hub.clients["previz"] += 1
    try:
        await relay_socket(ws, hub.previz, hub.stopping)
    finally:
        hub.clients["previz"] -= 1


previz_proxy.add_api_websocket_route("/previz", previz_socket)
previz_proxy.add_api_websocket_route("/previz/", previz_socket)
