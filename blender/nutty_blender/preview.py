"""What Check limits and Ghost send: the clip Export clip makes (so NLA, constraint and IK bakes apply
too), posted as `{"rate": <scene fps>, "clip": <nutty-clip/1>}`. The server plays it at the engine's
rate with the playback code and answers at the scene's frames (t = k / fps from the start frame), so
the ghost and the check show what the robot will play. A server older than that body (it asks for
`tracks`) gets the keyed DoFs sampled at each frame instead, with a note.
"""

from __future__ import annotations

from typing import Any

from . import clip
from .client import Client, NuttyError

PREVIEW_NAME = "blender_preview"  # the clip's name in the request (never stored)


def post(
    client: Client, route: str, scene: Any, rig_ob: Any, plan: Any, extra: dict[str, Any] | None = None
) -> tuple[dict[str, Any], list[str]]:
    """The server's answer to `route` (/api/analyze, /api/filter) for the rig's exported clip, and the
    export's notes. ExportError when there is nothing to send, NuttyError when the server refuses."""
    timing = clip.Timing.of(scene)
    doc, notes = clip.export_clip(rig_ob, plan, scene, PREVIEW_NAME)
    try:
        return client.post(route, {"rate": timing.fps, "clip": doc, **(extra or {})}), notes
    except NuttyError as exc:
        if exc.status != 422 or exc.field not in ("tracks", "clip"):
            raise
    tracks = clip.sample_tracks(rig_ob, plan, timing)  # an older server: sampled tracks, at the scene's fps
    if not tracks:
        raise clip.ExportError(f"'{rig_ob.name}' has no keyed DoFs to send to this (older) server")
    notes.append(
        f"{client.url} is older than this add-on: it judged the keys sampled at {timing.fps:g} fps, "
        f"not the clip at the engine's rate"
    )
    return client.post(route, {"rate": timing.fps, "tracks": tracks, **(extra or {})}), notes
