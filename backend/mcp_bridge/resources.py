"""The MCP server's resources, their subscriptions, and its prompt.

Resources: `nutty://robot` (the embodiment), `nutty://program` (the running program), `nutty://library`
(clips and postures) and `nutty://status` (what the robot is doing). A client may subscribe to them:
`nutty://status` is announced as updated whenever a command starts or ends (the server's /ws/control
events), `nutty://library` and `nutty://program` whenever the tools change. Handshake-era clients get
`notifications/resources/updated` on their session; 2026-era clients on their `subscriptions/listen`
stream.

The prompt `robot_brief` describes the robot for an agent's system prompt: what it is, its parts
(DoFs by dimension, with what each does), its postures and clips (with durations), and how its tools
behave.
"""

from __future__ import annotations

import logging
from typing import Any

from backend.mcp_bridge.remote import Remote

log = logging.getLogger(__name__)

STATUS, LIBRARY, PROGRAM, ROBOT = "nutty://status", "nutty://library", "nutty://program", "nutty://robot"
COMMAND_EVENTS = ("started", "completed", "cancelled", "failed", "queued")  # a status change
PROMPT = "robot_brief"
PROMPT_DESCRIPTION = "Describes the robot for an agent's system prompt: its parts, postures, clips and behaviours, and how its tools act."

RESOURCES = (  # uri, name, description, server path (None: from the tools' library section)
    (
        ROBOT,
        "robot",
        "The robot's embodiment: DoFs with units, limits and descriptions, postures.",
        "/api/robot",
    ),
    (
        PROGRAM,
        "program",
        "The running Animation Program: blocks, wires, exposed inputs, level.",
        "/api/program",
    ),
    (
        LIBRARY,
        "library",
        "The robot's clips (description, duration in s), postures (description), behaviours "
        "(description, parameters) and sounds.",
        None,
    ),
    (
        STATUS,
        "status",
        "What the robot is doing now: per-layer playback, posture move, gaze, mood, layer weights and the "
        "engine's health. Subscribe to be told when it changes.",
        "/api/tools/get_status",
    ),
)


async def read(remote: Remote, uri: str) -> Any:
    """The JSON of resource `uri`; ValueError for an unknown one, RuntimeError when the server refuses."""
    entry = next((r for r in RESOURCES if r[0] == uri), None)
    if entry is None:
        raise ValueError(f"unknown resource {uri} (resources: {[r[0] for r in RESOURCES]})")
    path = entry[3]
    answer = await (
        remote.request("POST", path, json={})
        if path and path.startswith("/api/tools/")
        else remote.request("GET", path or "/api/tools")
    )
    if not answer.ok:
        body = answer.body if isinstance(answer.body, dict) else {}
        raise RuntimeError(f"error {body.get('code', answer.status)}: {body.get('message', '')}")
    return answer.body["library"] if path is None else answer.body


def updated_by(event: dict[str, Any]) -> tuple[str, ...]:
    """The resources a /ws/control event changes."""
    name = event.get("event")
    if name in COMMAND_EVENTS:
        return (STATUS,)
    if name in ("tools_changed", "reconnected"):
        return (STATUS, LIBRARY, PROGRAM)
    return ()


def _parts(robot: dict[str, Any]) -> list[str]:
    lines = []
    for dimension in ("stationary", "spatial", "display", "audible"):
        dofs = [d for d in robot.get("dofs", []) if d.get("dimension") == dimension]
        if not dofs:
            continue
        lines.append(f"{dimension.capitalize()}:")
        for d in dofs:
            what = d.get("description") or d.get("type", "")
            unit = " (rad)" if d.get("type") == "continuous" and dimension == "stationary" else ""
            lines.append(f"- {d['name']}{unit}: {what}")
    return lines


def _behaviour_line(b: dict[str, Any]) -> str:
    """`- greet(name: string, target: vec3) (3.2 s): what it does`"""
    params = ", ".join(f"{name}: {p.get('type')}" for name, p in b.get("params", {}).items())
    return f"- {b['name']}({params}) ({b.get('duration') or 0:g} s): {b.get('description', '')}"


def brief(robot: dict[str, Any], library: dict[str, Any]) -> str:
    """The `robot_brief` prompt's text, from GET /api/robot and the tools' library section."""
    postures = [p if isinstance(p, str) else p.get("name", "") for p in robot.get("postures", [])]
    descriptions = {p["name"]: p.get("description", "") for p in library.get("postures", [])}
    lines = [
        f"You control '{robot.get('name')}', an expressive robot. {robot.get('description', '')}".strip(),
        "",
        "Its parts (degrees of freedom):",
        *_parts(robot),
        "",
        "Postures (set_posture):",
        *[f"- {p}: {descriptions.get(p, '')}".rstrip(": ") for p in postures],
        "",
        "Clips (play_clip):",
        *[
            f"- {c['name']} ({c.get('duration') or 0:g} s): {c.get('description', '')}"
            for c in library.get("clips", [])
        ],
        "",
        "Behaviours (play_behaviour: whole performances an animator timed, with parameters):",
        *(
            [_behaviour_line(b) for b in library.get("behaviours", [])]
            or ["- none yet (sequence clips, postures and speech with the tools)"]
        ),
        "",
        "How the tools act: long actions (play_behaviour, play_clip, set_posture, look_at, say, play_sound) "
        "answer at once "
        "with an id; pass wait: true to answer when the motion has ended, follow it with get_status(id), "
        "stop it with cancel(id). Give each call a request_id so a retry never repeats a gesture. look_at "
        "takes a point in metres in the robot's base frame (x forward, y left, z up) and says whether it "
        "is within reach. get_frame says where the robot is now. The robot's safety limits always hold: "
        "a motion may be slowed or clamped, never exceed them, and a finished action's outcome says what "
        "they changed.",
    ]
    return "\n".join(lines)


class Subscribers:
    """Handshake-era sessions subscribed to each resource (2026-era clients listen on their stream)."""

    def __init__(self) -> None:
        self._by_uri: dict[str, dict[int, Any]] = {}

    def add(self, uri: str, session: Any) -> None:
        self._by_uri.setdefault(uri, {})[id(session)] = session

    def remove(self, uri: str, session: Any) -> None:
        self._by_uri.get(uri, {}).pop(id(session), None)

    async def notify(self, uri: str) -> None:
        for key, session in list(self._by_uri.get(uri, {}).items()):
            try:
                await session.send_resource_updated(uri)
            except Exception as exc:  # that client is gone (its stream closed, whichever way)
                log.debug("resources/updated not delivered; forgetting that session: %s", exc, exc_info=True)
                self._by_uri[uri].pop(key, None)
