"""How a route reaches the server's state: the Hub `create_app` puts on `app.state`, as dependencies.

def robot(session: SessionDep) -> dict: ...
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends
from starlette.requests import HTTPConnection

from backend.hub import Hub
from backend.session import EngineSession


def get_hub(conn: HTTPConnection) -> Hub:
    """The Hub of the app serving this request or WebSocket."""
    return conn.app.state.hub


def get_session(conn: HTTPConnection) -> EngineSession:
    """The EngineSession the app serves."""
    return conn.app.state.hub.session


HubDep = Annotated[Hub, Depends(get_hub)]
SessionDep = Annotated[EngineSession, Depends(get_session)]
