"""The robot's sounds as files: list, fetch, store (the audio file as the body) and delete.

`PUT /api/sounds/{name}` takes the file's bytes (WAV, Ogg or FLAC; at most 20 MB and 5 minutes),
checks them with libsndfile, stores them as `robots/<robot>/sounds/<name>.<ext>` and makes the name one
of the sound DoF's sounds (when it follows the folder): the play_sound tool's list changes with it.
"""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse

from backend.api_types import Deleted, SoundEntry
from backend.engine.asset_errors import LibraryError, NotFound
from backend.engine.sounds import MAX_BYTES, SoundError
from backend.errors import DomainError
from backend.hub import Hub
from backend.routes.errors import api_error
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.tools import tools_changed

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["sounds"])
#: the request body limit of this router's paths (backend.api): a sound file and its headers' slack
SOUND_BODY = MAX_BYTES + 64 * 1024


def _refusal(exc: LibraryError) -> Exception:
    if isinstance(exc, NotFound):
        return DomainError(str(exc), code="not_found")
    if isinstance(exc, SoundError) and exc.code == "too_large":
        return api_error(413, "too_large", str(exc), field="body")
    code = exc.code if isinstance(exc, SoundError) else "invalid_audio"
    return DomainError(str(exc), code=code, field=exc.field)


async def _sounds_changed(hub: Hub) -> None:
    """The sound DoFs that follow the folder take its new list; AIs hear of the new tool list."""
    session = hub.session
    names = await asyncio.to_thread(session.library.sounds.list)
    session.embodiment.follow_sound_folder(names)
    await tools_changed(hub)


@router.get("/sounds", response_model=list[SoundEntry], summary="The robot's sound files")
def list_sounds(session: SessionDep) -> list[dict[str, Any]]:
    sounds = session.library.sounds
    out = []
    for name in sounds.list():
        try:
            out.append(sounds.info(name).to_dict())
        except LibraryError:  # a file libsndfile cannot read is not offered
            continue
    return out


@router.get(
    "/sounds/{name}",
    response_class=FileResponse,
    summary="A sound file (its own format: audio/wav, audio/ogg or audio/flac)",
    responses={
        200: {
            "content": {
                media: {"schema": {"type": "string", "format": "binary"}}
                for media in ("audio/ogg", "audio/wav", "audio/flac")
            }
        }
    },
)
def get_sound(name: str, session: SessionDep) -> FileResponse:
    try:
        info = session.library.sounds.info(name)
    except LibraryError as exc:
        raise _refusal(exc) from exc
    return FileResponse(info.path, media_type=info.media_type, headers={"Cache-Control": "no-cache"})


@router.put(
    "/sounds/{name}",
    response_model=SoundEntry,
    summary="Store a sound: the body is the audio file (WAV, Ogg or FLAC; at most 20 MB and 5 min)",
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {
                media: {"schema": {"type": "string", "format": "binary"}}
                for media in ("audio/wav", "audio/ogg", "audio/flac", "application/octet-stream")
            },
        }
    },
)
async def put_sound(name: str, request: Request, hub: HubDep) -> dict[str, Any]:
    data = await request.body()
    try:
        info = await asyncio.to_thread(hub.session.library.sounds.save, name, data)
    except LibraryError as exc:
        raise _refusal(exc) from exc
    await _sounds_changed(hub)
    return info.to_dict()


@router.delete("/sounds/{name}", response_model=Deleted, summary="Delete a sound file")
async def delete_sound(name: str, hub: HubDep) -> dict[str, Any]:
    try:
        await asyncio.to_thread(hub.session.library.sounds.delete, name)
    except LibraryError as exc:
        raise _refusal(exc) from exc
    await _sounds_changed(hub)
    return {"deleted": name}
