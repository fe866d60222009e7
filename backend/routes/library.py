"""The robot's library on disk: programs, clips, postures and subgraphs (list, read, save validated, delete).

(No `from __future__ import annotations` here: `add_kind` annotates its routes' bodies with a type
chosen per kind, which FastAPI must see as the type itself, not as a name to look up later.)
"""

import asyncio
import contextlib
from collections.abc import Iterator
from typing import Any

from fastapi import APIRouter

from backend.api_types import Deleted, Saved, StoredClip, StoredPosture, StoredProgram, StoredSubgraph
from backend.engine.library import LibraryError, NotFound
from backend.errors import DomainError
from backend.routes.bodies import ClipDoc, PostureDoc, ProgramDoc, SubgraphDoc
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
        raise DomainError(str(exc), code="not_found") from exc
    except LibraryError as exc:
        raise DomainError(str(exc), code="invalid_name") from exc


def add_kind(
    kind: str,
    doc_type: Any,
    stored: Any,
    validate_program: bool = False,
    validate_subgraph: bool = False,
) -> None:
    """GET/PUT/DELETE routes for one kind of asset; a PUT body is documented as `doc_type`, a GET
    answer as `stored`."""

    @router.get(f"/{kind}", response_model=list[str], summary=f"Names of the robot's {kind}")
    def list_items(session: SessionDep) -> list[str]:
        return session.library.list(kind)

    @router.get(f"/{kind}/{{name}}", response_model=stored, summary=f"One of the robot's {kind}")
    def get_item(name: str, session: SessionDep) -> dict[str, Any]:
        with _lookup_errors():
            return session.library.get(kind, name)

    @router.put(
        f"/{kind}/{{name}}",
        response_model=Saved,
        summary=f"Save one of the robot's {kind} (validated against its format)",
    )
    async def put_item(
        name: str,
        doc: doc_type,  # pyright: ignore[reportInvalidTypeForm]  # each kind's body model, chosen when its routes are made
        session: SessionDep,
        hub: HubDep,
    ) -> dict[str, Any]:
        if not isinstance(doc, dict):
            raise DomainError(f"a {kind[:-1]} is a JSON object", code="invalid_document")
        try:
            session.library.check_name(name)
        except LibraryError as exc:
            raise DomainError(str(exc), code="invalid_name") from exc
        if validate_program:
            report = await asyncio.to_thread(session.validate, doc)
            if not report.valid:
                raise DomainError("program is invalid", code="invalid_program", report=report.model_dump())
        if validate_subgraph:
            report = await asyncio.to_thread(session.validate_subgraph, name, doc)
            if not report.valid:
                raise DomainError("subgraph is invalid", code="invalid_subgraph", report=report.model_dump())
        try:
            stored = await asyncio.to_thread(session.library.save, kind, name, doc)
        except LibraryError as exc:
            raise DomainError(str(exc), code="invalid_document", field=exc.field) from exc
        await tools_changed(hub)  # a clip or posture is part of the AI tools' vocabulary
        warnings = await asyncio.to_thread(session.library.joint_warnings, kind, stored)
        return {"saved": name, "warnings": warnings} if warnings else {"saved": name}

    @router.delete(f"/{kind}/{{name}}", response_model=Deleted, summary=f"Delete one of the robot's {kind}")
    async def delete_item(name: str, session: SessionDep, hub: HubDep) -> dict[str, Any]:
        with _lookup_errors():
            await asyncio.to_thread(session.library.delete, kind, name)
        await tools_changed(hub)
        return {"deleted": name}


add_kind("programs", ProgramDoc, StoredProgram, validate_program=True)
add_kind("clips", ClipDoc, StoredClip)
add_kind("postures", PostureDoc, StoredPosture)
add_kind("subgraphs", SubgraphDoc, StoredSubgraph, validate_subgraph=True)
