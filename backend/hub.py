"""The server's state around one EngineSession: the command log, connected clients, and the event
fan-out to every /ws/control client.

Commands from REST and /ws/control both go through `Hub.run_command` (validate, log, execute, ack)
and `Hub.cancel`; their events reach clients in one shape (docs/api-contract.md): every command gets
at most one `started` and one terminal event (`completed`, `cancelled` or `failed`), all under its id.
A refused command raises a `DomainError` (backend.errors) with its code; each edge (HTTP, WebSocket,
Zenoh) answers it in its own way.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable
from typing import Any

from backend import control
from backend.action_watch import ActionWatch
from backend.errors import DomainError
from backend.pose_preview import PosePreview
from backend.session import EngineSession
from backend.take_recorder import TakeRecorder

TERMINAL = ("completed", "cancelled", "failed")
log = logging.getLogger(__name__)


def jsonable(v: Any) -> bool:
    """Whether `v` is a JSON value as it stands (no conversion needed)."""
    return isinstance(v, (str, int, float, bool, type(None), list, dict))


def put_drop_oldest(q: asyncio.Queue, item: Any) -> None:
    """Queue `item`, dropping the oldest one when full: a slow client loses messages, never blocks."""
    if q.full():
        with contextlib.suppress(asyncio.QueueEmpty):
            q.get_nowait()
    q.put_nowait(item)


class CommandLog:
    """Commands by id with their status, for GET /api/commands/{id}, cancellation and the event
    stream: each command gets at most one `started` and one terminal event (completed, cancelled
    or failed), and nothing after its terminal event."""

    def __init__(self, size: int = 500):
        self._items: dict[str, dict[str, Any]] = {}
        self._flags: dict[str, list[bool]] = {}  # id -> [started sent, terminal sent]
        self._order: deque[str] = deque()
        self._size = size
        self._lock = threading.Lock()

    def add(self, cid: str, command: Any) -> dict[str, Any]:
        """Log a new command; a live command with the same id is a DomainError `duplicate_id`."""
        entry = {
            "id": cid,
            "type": command.type,
            "status": "accepted",
            "created": time.time(),
            "result": None,
        }
        with self._lock:
            old = self._items.get(cid)
            if old is not None and old["status"] not in TERMINAL:
                raise DomainError(
                    f"command '{cid}' is still {old['status']}: choose another id",
                    code="duplicate_id",
                    field="id",
                    id=cid,
                )
            if old is not None:
                self._order.remove(cid)
            self._items[cid] = entry
            self._flags[cid] = [False, False]
            self._order.append(cid)
            while len(self._order) > self._size:
                gone = self._order.popleft()
                self._items.pop(gone, None)
                self._flags.pop(gone, None)
        return entry

    def get(self, cid: Any) -> dict[str, Any] | None:
        return self._items.get(cid) if isinstance(cid, str) else None

    def update(self, cid: str | None, **fields: Any) -> None:
        with self._lock:
            if cid and cid in self._items:
                self._items[cid].update(fields)

    def handed_over(self, cid: str, queued: bool = False) -> None:
        """The command went to a block, which reports its events itself: it counts as started, or as
        `queued` when the block starts it later (its `started` event then marks it started)."""
        with self._lock:
            entry = self._items.get(cid)
            if entry is not None and entry["status"] == "accepted":
                entry["status"] = "queued" if queued and not self._flags[cid][0] else "started"

    def transition(self, cid: str | None, event: str | None) -> tuple[bool, str | None]:
        """Whether an event for command `cid` may go out, and the command's type (None if unknown)."""
        with self._lock:
            entry = self._items.get(cid) if cid else None
            if entry is None or cid is None:
                return True, None
            flags = self._flags[cid]
            if event == "started":
                if flags[0] or flags[1]:
                    return False, entry["type"]
                flags[0] = True
                if entry["status"] in ("accepted", "queued"):
                    entry["status"] = "started"
                return True, entry["type"]
            if event in TERMINAL:
                if flags[1]:
                    return False, entry["type"]
                flags[1] = True
                entry["status"] = event
                return True, entry["type"]
            return not flags[1], entry["type"]


class Hub:
    """Shared server state: the session, connected clients, the event fan-out to /ws/control."""

    def __init__(self, session: EngineSession, token: str | None, previz: Any = None):
        self.session = session
        self.token = token
        self.previz = previz
        self.commands = CommandLog()
        self.clients = {"control": 0, "telemetry": 0, "frames": 0, "previz": 0}
        self.control_queues: set[asyncio.Queue] = set()  # one per /ws/control client
        self.loop: asyncio.AbstractEventLoop | None = None
        self.stopping: asyncio.Event | None = None  # set when the app shuts down (lifespan)
        self.tools_revision: str | None = None  # of the AI tools last announced (backend.routes.tools)
        # Called with every message broadcast to /ws/control clients, from the thread that emits it (the
        # clock thread, for block events): e.g. the Zenoh link (backend/zenoh_link). Keep them quick.
        self.listeners: list[Callable[[dict[str, Any]], None]] = []
        # what became of each long action: its completion held until the motion has ended, and what
        # the safety net did to it (backend/action_watch.py)
        self.actions = ActionWatch(session.embodiment, self._completed)
        # the clip editor's preview pose in the Pre-Viz, and the take being recorded (backend/routes/takes.py)
        self.pose_preview = PosePreview(session.embodiment, previz)
        if previz is not None:
            previz.on_pose_grab = self.pose_preview.grab
        self.take: TakeRecorder | None = None
        session.engine.add_frame_observer(self.actions.observe)
        session.on_note(self._on_note)

    def shutdown(self) -> None:
        """Tell every WebSocket handler to finish (thread-safe)."""
        loop, ev = self.loop, self.stopping
        if loop is not None and ev is not None and not loop.is_closed():
            loop.call_soon_threadsafe(ev.set)

    def _on_note(self, note: dict[str, Any]) -> None:
        """Block notifications arrive on the clock thread: record them and hand them to the event loop.
        A long action's `completed` waits in `actions` until the robot's motion has ended."""
        cid = note.get("command_id")
        if self.session.behaviours.owns(cid):
            return  # a behaviour's item command: the behaviour reports it as an `item` event
        event = note.get("event")
        entry = self.commands.get(cid)
        if (
            event == "completed"
            and isinstance(cid, str)
            and entry is not None
            and entry["status"] not in TERMINAL
        ):
            self.actions.hold(cid, note)
            return
        self._note_out(cid, event, note)

    def _completed(self, cid: str, note: dict[str, Any]) -> None:
        """A held completion, its `outcome` filled in (on the action watch's thread)."""
        self.commands.update(cid, outcome=note.get("outcome"))
        self._note_out(cid, "completed", note)

    def _note_out(self, cid: Any, event: Any, note: dict[str, Any]) -> None:
        if event in ("cancelled", "failed") and cid is not None and "outcome" not in note:
            note = {**note, "outcome": self.actions.closed(cid)}
            self.commands.update(cid, outcome=note["outcome"])
        ok, ctype = self.commands.transition(cid, event)
        if not ok:
            return
        if event == "started" and cid is not None:
            self.actions.opened(cid)
        details = {  # "_" keys are for the server (e.g. the channels an action moved)
            k: v
            for k, v in note.items()
            if k not in ("command_id", "event", "id", "type") and not k.startswith("_") and jsonable(v)
        }
        message = {"type": "event", "event": event, "id": cid, **details}
        if ctype is not None:
            message["command"] = ctype
        self.broadcast(message)

    def _emit(self, cid: str, event: str, **details: Any) -> None:
        if event in ("cancelled", "failed"):
            details["outcome"] = self.actions.closed(cid)
            self.commands.update(cid, outcome=details["outcome"])
        ok, ctype = self.commands.transition(cid, event)
        if ok:
            self.broadcast({"type": "event", "event": event, "id": cid, "command": ctype, **details})

    def broadcast(self, message: dict[str, Any]) -> None:
        for fn in list(self.listeners):
            try:
                fn(message)
            except Exception:  # a listener's fault never stops the events to the sockets
                log.exception("event listener %r failed on a %s message", fn, message.get("event"))
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        for q in list(self.control_queues):
            try:
                loop.call_soon_threadsafe(put_drop_oldest, q, message)
            except RuntimeError:  # the loop closed meanwhile
                return

    def run_command(self, data: Any) -> dict[str, Any]:
        """Validate, log and execute one command (a JSON object); returns the ack.

        Raises a DomainError: the parser's CommandError for a malformed command (not logged); once the
        command is logged, its CommandError with its `id` (`no_target`, `busy`, ...), `duplicate_id`
        for the id of a command still running, or `rejected` when carrying it out failed.
        """
        cmd = control.parse_command(data)
        cid = cmd.id or uuid.uuid4().hex[:12]
        entry = self.commands.add(cid, cmd)
        try:
            result = control.execute(self.session, cmd, cid, cancel=self._cancel_target)
        except control.CommandError as exc:
            self._fail(cid, exc)
            raise control.CommandError(str(exc), exc.field, exc.code, **{**exc.extra, "id": cid}) from exc
        except (ValueError, TypeError, KeyError, TimeoutError) as exc:
            self._fail(cid, exc)
            raise DomainError(str(exc), code="rejected", id=cid) from exc
        done = isinstance(result, dict) and result.get("done")
        self.commands.update(cid, result=result if jsonable(result) else None)
        if cmd.long_action and not done:
            # Its block reports started/completed/cancelled (see _on_note); a queued one starts later.
            self.commands.handed_over(cid, queued=isinstance(result, dict) and bool(result.get("queued")))
        else:
            self._emit(cid, "completed")
        return {"id": cid, "status": entry["status"], "result": entry["result"]}

    def _fail(self, cid: str, exc: Exception) -> None:
        self.commands.update(cid, result=str(exc))
        self.commands.transition(cid, "failed")

    def _cancel_target(self, target: str) -> dict[str, Any]:
        """The `cancel` command's work: the target gets its `cancelled` event (the cancel is acked)."""
        if self.commands.get(target) is None:
            raise control.CommandError(
                f"no command with id '{target}'", field="target", code="unknown_command"
            )
        return {"target": target, "status": self.cancel(target)["status"]}

    def cancel(self, cid: str) -> dict[str, Any]:
        """Cancel a long action by id (DELETE /api/commands/{id}); a finished one keeps its status.
        DomainError `unknown_command` for an id nobody sent."""
        entry = self.commands.get(cid)
        if entry is None:
            raise DomainError(f"no command with id '{cid}'", code="unknown_command")
        if entry["status"] in TERMINAL:
            return {"id": cid, "status": entry["status"]}
        control.cancel_command(self.session, entry["type"], cid)
        self._emit(cid, "cancelled")
        now = self.commands.get(cid)
        return {"id": cid, "status": now["status"] if now else "cancelled"}
