"""An engine on Zenoh (`nutty serve --zenoh`): its frames, status and events out, commands and queries in.

`EngineLink.open` joins Zenoh and makes sure no live engine already has the robot id; `start(hub)`
declares the robot's keys (backend/zenoh_link/keys.py) around the server's `Hub`:

- every frame goes out on `frames` from an engine sink (its own thread and bounded queue: a slow
  network drops frames, counted, and never slows the clock), stamped with its emission time;
- `status` is published every second and answers queries, as do `robot` and `program`;
- a command on `commands` takes the path a REST or /ws/control command takes, `Hub.run_command`:
  the same JSON rules, the same typed union, the same command log and events under the command's
  id. A query gets the ack (or the error) as its reply; a put gets it on `events`. Commands run one
  at a time on one worker thread, like the messages of one /ws/control client;
- every event the Hub broadcasts to /ws/control clients is published on `events`;
- a liveliness token on `alive`, declared last and withdrawn first, tells others the engine is there.

A refused command (the core's `DomainError`) is answered with the HTTP status REST would have used
(`backend.routes.errors.http_status`, the one table from error code to status) and its error object.
While the server shuts down (`closing` set) commands are refused with `shutting_down`, as the HTTP
API refuses them; the frames of the park still go out, so a bridge follows the robot to rest.
Who may publish commands is Zenoh's business: access control and TLS in the Zenoh configuration
(docs/fleet.md).
"""

from __future__ import annotations

import logging
import secrets
import threading
import time
from typing import Any

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink
from backend.remote_commands import CommandWorker, error_reply, server_status
from backend.routes.program import get_program
from backend.routes.robot import robot
from backend.zenoh_link import keys
from backend.zenoh_link.codec import (
    SESSION_BYTES,
    encode_frame,
    encode_json,
    payload_bytes,
    stamp,
)
from backend.zenoh_link.session import ZenohOptions, ZenohSetupError, settle

STATUS_PERIOD = 1.0  # s between status publications
log = logging.getLogger(__name__)


class FramePublisher(Sink[Any]):  # offered frames, queued as (frame, stamp) pairs
    """Every frame on `nutty/<id>/frames` (msgpack, as /ws/frames), with its emission time attached.

    The time is the tick's that made the frame (`AnimationFrame.made`), so a receiver's latency counts
    the fan-out and this sink's queue too, as a /ws/frames client's does.
    """

    def __init__(
        self, publisher: Any, embodiment: Embodiment, max_queue: int = 64, session: bytes | None = None
    ):
        self.publisher, self.emb, self.session = publisher, embodiment, session
        super().__init__("zenoh-frames", max_queue=max_queue)

    def offer(self, frame: AnimationFrame) -> None:
        # the queue holds (frame, wall time it was made) pairs
        super().offer((frame, time.time() if frame.made is None else frame.made))

    def consume(self, frame: Any) -> None:
        frame, sent = frame
        self.publisher.put(encode_frame(frame, self.emb), attachment=stamp(sent, self.session))


class EngineLink:
    """One engine's presence on Zenoh under `nutty/<robot_id>/` (see the module doc)."""

    def __init__(
        self,
        session: Any,  # a zenoh.Session (zenoh is imported only where a link is made)
        robot_id: str,
        options: ZenohOptions | None = None,
        status_period: float = STATUS_PERIOD,
    ):
        self.session = session
        self.robot_id = keys.check_robot_id(robot_id)
        self.options = options or ZenohOptions()
        self.status_period = status_period
        self.hub: Any = None  # the server Hub, from start()
        self.closing: threading.Event | None = None
        self.key = {
            leaf: keys.key(robot_id, leaf)
            for leaf in (
                keys.ALIVE,
                keys.FRAMES,
                keys.STATUS,
                keys.EVENTS,
                keys.COMMANDS,
                keys.ROBOT,
                keys.PROGRAM,
            )
        }
        self.commands = CommandWorker("zenoh", self._answer)
        self._queries = 0
        #: This run's session id: frames carry it, a liveliness token names it (bridges follow only it).
        self.session_id = secrets.token_bytes(SESSION_BYTES)
        self._declared: list[Any] = []
        self._token: Any = None
        self._session_token: Any = None
        self._frames: FramePublisher | None = None
        self._events: Sink | None = None
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._closed = False

    # --- joining ----------------------------------------------------------------------------------
    @classmethod
    def open(cls, options: ZenohOptions, robot_id: str, *, check_timeout: float = 1.0) -> EngineLink:
        """Join Zenoh as `robot_id`; ZenohSetupError when Zenoh refuses or a live engine has that id."""
        session = options.open()
        try:
            settle(session, options)
            taken = any(
                r.ok is not None
                for r in session.liveliness().get(keys.key(robot_id, keys.ALIVE), timeout=check_timeout)
            )
        except Exception:
            session.close()
            raise
        if taken:
            session.close()
            raise ZenohSetupError(
                f"robot id '{robot_id}' is taken: a live engine already publishes "
                f"{keys.key(robot_id, '**')} (choose another --robot-id)"
            )
        return cls(session, robot_id, options)

    def start(self, hub: Any, closing: threading.Event | None = None) -> EngineLink:
        """Declare everything around the server's Hub; the liveliness token last."""
        import zenoh  # Zenoh's native library loads only when an engine goes on Zenoh

        self.hub, self.closing = hub, closing
        s, k = self.session, self.key
        frames = s.declare_publisher(
            k[keys.FRAMES],
            encoding=zenoh.Encoding("application/msgpack"),
            congestion_control=zenoh.CongestionControl.DROP,
            priority=zenoh.Priority.REAL_TIME,
            express=True,
        )
        self._status_pub = s.declare_publisher(k[keys.STATUS], encoding=zenoh.Encoding.APPLICATION_JSON)
        self._events_pub = s.declare_publisher(k[keys.EVENTS], encoding=zenoh.Encoding.APPLICATION_JSON)
        self._declared += [frames, self._status_pub, self._events_pub]
        self._declared.append(s.declare_subscriber(k[keys.COMMANDS], self._on_put))
        self._declared.append(s.declare_queryable(k[keys.COMMANDS], self._on_command_query))
        for leaf in keys.QUERIES:  # each answers for its own leaf, also to a wider query such as nutty/**
            self._declared.append(
                s.declare_queryable(k[leaf], lambda q, leaf=leaf: self._on_read_query(q, leaf))
            )
        self._events = Sink("zenoh-events", lambda m: self._events_pub.put(encode_json(m)), max_queue=256)
        hub.listeners.append(self._events.offer)
        self._frames = hub.session.engine.add_sink(
            FramePublisher(frames, hub.session.embodiment, session=self.session_id)
        )
        self.commands.start(hub, closing)
        t = threading.Thread(target=self._status_loop, name="zenoh-status", daemon=True)
        t.start()
        self._threads.append(t)
        self._session_token = s.liveliness().declare_token(
            keys.session_key(self.robot_id, self.session_id.hex())
        )
        self._token = s.liveliness().declare_token(k[keys.ALIVE])
        return self

    # --- commands ---------------------------------------------------------------------------------
    def _on_put(self, sample: Any) -> None:
        if keys.is_command_key(sample.key_expr):  # not from a wider key: see keys.is_command_key
            self._enqueue(payload_bytes(sample.payload), None)

    def _on_command_query(self, query: Any) -> None:
        if not keys.is_command_key(query.key_expr):
            self._answer(
                query,
                error_reply(
                    400,
                    "not_a_command_key",
                    f"commands are taken on {keys.ROOT}/<robot id or pattern>/commands only",
                ),
            )
            return
        self._enqueue(payload_bytes(query.payload), query)

    @property
    def counts(self) -> dict[str, int]:
        """Commands run, refused (`errors`), refused for a full queue (`busy`), and read queries."""
        return {**self.commands.counts, "queries": self._queries}

    def _enqueue(self, payload: bytes, query: Any) -> None:
        self.commands.submit(payload, query)

    def run(self, payload: bytes) -> dict[str, Any]:
        """Carry out one command message; the ack or error answer (backend/remote_commands.py)."""
        return self.commands.run(payload)

    def _answer(self, query: Any, reply: dict[str, Any]) -> None:
        """A query's reply, or (for a put) a message on `events` for whoever watches."""
        try:
            if query is not None:
                query.reply(self.key[keys.COMMANDS], encode_json(reply))
                query.drop()
            elif self._events is not None:
                self._events.offer(reply)
        except Exception:  # the asker left, or the session is closing: nobody to tell
            log.debug("Zenoh: answering a command failed", exc_info=True)

    # --- reads ------------------------------------------------------------------------------------
    def _on_read_query(self, query: Any, leaf: str) -> None:
        self._queries += 1
        try:
            reply = self.read(leaf)
        except Exception as exc:  # the asker gets an error answer; the queryable stays
            log.exception("Zenoh: reading %s failed", leaf)
            reply = error_reply(500, "internal_error", f"cannot read {leaf}: {type(exc).__name__}")
        try:
            query.reply(self.key[leaf], encode_json(reply))
            query.drop()  # the asker's get ends now, not when Python collects the query
        except Exception:  # the asker left, or the session is closing: nobody to tell
            log.debug("Zenoh: answering a query on %s failed", leaf, exc_info=True)

    def read(self, leaf: str) -> Any:
        """The answer to a query on `robot`, `program` or `status` (as GET /api/<leaf> answers)."""
        session = self.hub.session
        if leaf == keys.ROBOT:
            return robot(session)
        if leaf == keys.PROGRAM:
            return get_program(session)
        if leaf == keys.STATUS:
            return self.status()
        raise KeyError(leaf)

    def status(self) -> dict[str, Any]:
        """`GET /api/status` without the Pre-Viz's URLs (they depend on the HTTP request), plus the
        robot id and this link's counters."""
        stats = server_status(self.hub)
        stats["robot_id"] = self.robot_id
        stats["zenoh"] = self.counts
        return stats

    def _status_loop(self) -> None:
        while not self._stop.wait(self.status_period):
            try:
                self._status_pub.put(encode_json(self.status()))
            except Exception:  # the session may be closing; the next period tries again
                log.debug("Zenoh: publishing the status failed", exc_info=True)

    # --- leaving ----------------------------------------------------------------------------------
    def close(self) -> None:
        """Withdraw the token, stop the threads, deliver what is queued, close the session (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for step in (self._withdraw, self._stop_threads, self._detach):
            try:
                step()
            except Exception:  # each step is tried: a failed one must not keep the session open
                log.warning("Zenoh link: %s failed while closing", step.__name__, exc_info=True)
        self.session.close()

    def _withdraw(self) -> None:
        for token in (self._token, self._session_token):
            if token is not None:
                token.undeclare()

    def _stop_threads(self) -> None:
        self._stop.set()
        self.commands.stop()  # commands that never ran: their askers get a clear no
        for t in self._threads:
            t.join(3.0)

    def _detach(self) -> None:
        if self.hub is not None:
            if self._events is not None and self._events.offer in self.hub.listeners:
                self.hub.listeners.remove(self._events.offer)
            if self._frames is not None:
                self.hub.session.engine.remove_sink(self._frames)
        if self._events is not None:
            self._events.close(1.0)
        for entity in reversed(self._declared):
            entity.undeclare()
