"""Commands from a message bus (Zenoh, ROS 2): the same path as REST and /ws/control, on a worker.

A link hands each command message (JSON bytes) to a `CommandWorker` with whatever it needs to answer
(a Zenoh query, or nothing); the worker runs them one at a time on its own thread, as the messages of
one /ws/control client, through `Hub.run_command` (the same JSON rules, typed union, command log and
events), and gives `answer(reply_to, reply)` the ack or the error. A refused command (the core's
`DomainError`) is answered with the HTTP status REST would have used and its error object. While the
server shuts down (`closing` set) commands are refused with `shutting_down`. `server_status(hub)` is
`GET /api/status` without the Pre-Viz's URLs, which depend on the HTTP request.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any

from backend.errors import DomainError
from backend.routes.errors import error_detail, http_status
from backend.safe_json import JsonSafetyError, decode_message
from backend.shutdown import SHUTTING_DOWN

COMMAND_QUEUE = 64  # commands waiting for the worker; more are refused with `busy`
log = logging.getLogger(__name__)


def error_reply(status: int, code: str, message: str, **extra: Any) -> dict[str, Any]:
    """An error answer: the /ws/control error shape plus the HTTP `status` REST would have used."""
    return {"type": "error", "status": status, "code": code, "message": message, **extra}


def server_status(hub: Any) -> dict[str, Any]:
    """`GET /api/status` without the Pre-Viz's URLs."""
    stats = hub.session.engine.stats()
    stats["clients"] = dict(hub.clients)
    stats["program"] = hub.session.program.name if hub.session.program else None
    stats["previz"] = (
        {"frames_shown": hub.previz.frames_shown, "ghost": hub.previz.ghost_visible} if hub.previz else None
    )
    return stats


class CommandWorker:
    """Runs command messages for one link (see the module doc); `counts` of commands, errors, busy."""

    def __init__(
        self,
        name: str,
        answer: Callable[[Any, dict[str, Any]], None],
        closing: threading.Event | None = None,
    ):
        self.name, self.answer, self.closing = name, answer, closing
        self.hub: Any = None
        self.counts = {"commands": 0, "errors": 0, "busy": 0}
        self._work: queue.Queue = queue.Queue(maxsize=COMMAND_QUEUE)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, hub: Any, closing: threading.Event | None = None) -> None:
        self.hub = hub
        if closing is not None:
            self.closing = closing
        self._thread = threading.Thread(target=self._loop, name=f"{self.name}-commands", daemon=True)
        self._thread.start()

    def submit(self, payload: bytes, reply_to: Any = None) -> None:
        """Queue one message (any thread); a full queue answers `busy` at once."""
        try:
            self._work.put_nowait((payload, reply_to))
        except queue.Full:
            self.counts["busy"] += 1
            self.answer(
                reply_to,
                error_reply(503, "busy", f"more than {COMMAND_QUEUE} commands are waiting; try again"),
            )

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                payload, reply_to = self._work.get(timeout=0.2)
            except queue.Empty:
                continue
            try:
                reply = self.run(payload)
            except Exception:  # never let one message stop the worker
                log.exception("%s command worker: a message failed", self.name)
                reply = error_reply(500, "internal_error", "the server could not handle this message")
            self.answer(reply_to, reply)

    def run(self, payload: bytes) -> dict[str, Any]:
        """Carry out one command message; the ack or error answer (the /ws/control shapes)."""
        self.counts["commands"] += 1
        if self.closing is not None and self.closing.is_set():
            return self._failed(error_reply(503, "shutting_down", SHUTTING_DOWN))
        try:
            data = decode_message(payload)
        except JsonSafetyError as exc:
            extra = {"field": exc.field} if exc.field else {}
            return self._failed(error_reply(exc.status, exc.code, str(exc), **extra))
        cid = data.get("id") if isinstance(data, dict) and isinstance(data.get("id"), str) else None
        try:
            ack = self.hub.run_command(data)
        except DomainError as exc:
            return self._failed(error_reply(http_status(exc), **error_detail(exc, id=cid)))
        except Exception:  # a fault of the server, not of the message: say so, keep the worker
            log.exception("%s command %r failed", self.name, cid)
            return self._failed(
                error_reply(500, "internal_error", "the server could not carry out this command", id=cid)
            )
        return {"type": "ack", **ack}

    def _failed(self, reply: dict[str, Any]) -> dict[str, Any]:
        self.counts["errors"] += 1
        return reply

    def stop(self) -> None:
        """Stop the worker; commands that never ran get `shutting_down`."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(3.0)
        while True:
            try:
                _, reply_to = self._work.get_nowait()
            except queue.Empty:
                break
            self.answer(reply_to, error_reply(503, "shutting_down", SHUTTING_DOWN))
