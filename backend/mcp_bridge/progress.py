"""A waited tool call with MCP progress: when a client asks for progress (a progress token) on a long
action with `wait: true`, the call is sent without waiting, and the action is followed by long-polling
get_status for its id (at most `POLL` s per poll) until it ends or the call's own `timeout` passes;
each change of its fraction (a clip's playhead over its duration, a posture move's elapsed time over
its duration) goes out as a progress notification, and 1.0 when it ends. The answer is the one a
waiting call gets: the first answer, with the status the action ended with.
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from typing import Any

from backend.mcp_bridge.remote import Answer, Remote

POLL = 0.25  # s: the longest a progress report can lag the action
OPEN = ("accepted", "queued", "started")
DEFAULT_TIMEOUT = 30.0  # s, as WaitOptions

Report = Callable[[float, str], Awaitable[None]]


def command_progress(status: dict[str, Any], cid: str) -> float | None:
    """The fraction (0..1) done of command `cid` from a get_status answer: its clip's or its posture
    move's progress; 0 while it waits in a queue; None when the status does not say (speech)."""
    for player in status.get("playing") or []:
        if player.get("command_id") == cid and player.get("progress") is not None:
            return float(player["progress"])
        if any(q.get("command_id") == cid for q in player.get("queued") or []):
            return 0.0
    for posture in status.get("posture") or []:
        move = posture.get("move") or {}
        if move.get("command_id") == cid and move.get("progress") is not None:
            return float(move["progress"])
    return None


async def call_with_progress(remote: Remote, name: str, arguments: dict[str, Any], report: Report) -> Answer:
    """Carry out a long action's tool call as `wait: true` does, reporting its progress (module doc)."""
    timeout = arguments.get("timeout", DEFAULT_TIMEOUT)
    timeout = float(timeout) if isinstance(timeout, (int, float)) and not isinstance(timeout, bool) else 30.0
    first = await remote.call(name, {**arguments, "wait": False})
    if not first.ok or first.body.get("status") not in OPEN:
        return first
    cid = first.body["id"]
    deadline = time.monotonic() + timeout
    last: float | None = None
    entry: dict[str, Any] = {"status": first.body["status"]}
    while True:
        remaining = deadline - time.monotonic()
        polled = await remote.call(
            "get_status", {"id": cid, "wait": True, "timeout": max(0.05, min(POLL, remaining))}
        )
        if not polled.ok:
            return polled
        entry = polled.body.get("command") or entry
        done = entry.get("status") not in OPEN
        fraction = 1.0 if done else command_progress(polled.body, cid)
        if fraction is not None and fraction != last:
            await report(fraction, f"{name}: {entry.get('status')}")
            last = fraction
        if done or remaining <= 0:
            break
    body = {
        **first.body,
        "status": entry.get("status"),
        "waited": True,
        "timed_out": not done,
        "outcome": entry.get("outcome"),
    }
    return Answer(True, 200, body)
