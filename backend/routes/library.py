"""The robot's library on disk: programs, clips, postures and subgraphs (list, read, save validated, delete).

(No `from __future__ import annotations` here: `add_kind` annotates its routes' bodies with a type
chosen per kind, which FastAPI must see as the type itself, not as a name to look up later.)
"""

import asyncio
import contextlib
from collections.abc import Iterator
from typing import Any

from fastapi import APIRouter

from backend.engine.library import LibraryError, NotFound
from backend.routes.bodies import ClipDoc, PostureDoc, ProgramDoc, SubgraphDoc
from backend.routes.errors import api_error
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.tools import tools_changed

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["library"])


@contextlib.contextmanager
def _lookup_errors() -> Iterator[None]:
    """A missing asset is a 404 `not_found`, a malformed name a 422 `invalid_name`."""
    try:
        yield
    except NotFound as exc:
        raise api_error(404, "not_found", str(exc)) from exc
    except LibraryError as exc:
        raise api_error(422, "invalid_name", str(exc)) from exc


def add_kind(
    kind: str, doc_type: Any, validate_program: bool = False, validate_subgraph: bool = False
) -> None:
    """GET/PUT/DELETE routes for one kind of asset; a PUT body is documented as `doc_type`."""

    @router.get(f"/{kind}", summary=f"Names of the robot's {kind}")
    def list_items(session: SessionDep) -> list[str]:
        return session.library.list(kind)

    @router.get(f"/{kind}/{{name}}", summary=f"One of the robot's {kind}")
    def get_item(name: str, session: SessionDep) -> dict[str, Any]:
        with _lookup_errors():
            return session.library.get(kind, name)

    @router.put(f"/{kind}/{{name}}", summary=f"Save one of the robot's {kind} (validated against its format)")
    async def put_item(name: str, doc: doc_type, session: SessionDep, hub: HubDep) -> dict[str, Any]:
        if not isinstance(doc, dict):
            raise api_error(422, "invalid_document", f"a {kind[:-1]} is a JSON object")
        try:
            session.library.check_name(name)
        except LibraryError as exc:
            raise api_error(422, "invalid_name", str(exc)) from exc
        if validate_program:
            report = await asyncio.to_thread(session.validate, doc)
            if not report.valid:
                raise api_error(422, "invalid_program", "program is invalid", report=report.model_dump())
        if validate_subgraph:
            report = await asyncio.to_thread(session.validate_subgraph, name, doc)
            if not report.valid:
                raise api_error(422, "invalid_subgraph", "subgraph is invalid", report=report.model_dump())
        try:
            stored = await asyncio.to_thread(session.library.save, kind, name, doc)
        except LibraryError as exc:
            raise api_error(422, "invalid_document", str(exc)) from exc
        await tools_changed(hub)  # a clip or posture is part of the AI tools' vocabulary
        warnings = await asyncio.to_thread(session.library.joint_warnings, kind, stored)
        return {"saved": name, "warnings": warnings} if warnings else {"saved": name}

    @router.delete(f"/{kind}/{{name}}", summary=f"Delete one of the robot's {kind}")
    async def delete_item(name: str, session: SessionDep, hub: HubDep) -> dict[str, Any]:
        with _lookup_errors():
            await asyncio.to_thread(session.library.delete, kind, name)
        await tools_changed(hub)
        return {"deleted": name}


add_kind("programs", ProgramDoc, validate_program=True)
add_kind("clips", ClipDoc)
add_kind("postures", PostureDoc)
add_kind("subgraphs", SubgraphDoc, validate_subgraph=True)
