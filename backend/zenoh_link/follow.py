"""One robot's engine, followed over Zenoh by a robot-side bridge (`nutty bridge`): its tick rate and
its frames (the robot's description and limits are the bridge's own files, never the network's)."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from backend.zenoh_link import keys
from backend.zenoh_link.codec import frame_of, json_of, read_session

log = logging.getLogger(__name__)


def ask_one(session: Any, robot_id: str, leaf: str, timeout: float = 2.0) -> Any:
    """The JSON answer of `robot_id` on `leaf`, or None when it did not answer within `timeout` s."""
    for reply in session.get(keys.key(robot_id, leaf), timeout=timeout):
        if reply.ok is not None:
            try:
                answer = json_of(reply.ok)
            except ValueError:
                continue
            if not (isinstance(answer, dict) and answer.get("type") == "error"):
                return answer
    return None


def wait_for_engine(
    session: Any,
    robot_id: str,
    *,
    rate: float | None,
    wait: float,
    log: Callable[[str], None],
    stop: threading.Event | None = None,
) -> float:
    """The engine's tick rate (asked of the engine unless given), waiting up to `wait` s for it to answer
    (or until `stop` is set: 0.0 then); TimeoutError when it does not. Only the pace comes from the
    engine: the robot and its limits are the bridge's own (and the frames' dt is followed, per session)."""
    deadline = time.monotonic() + wait
    told = False
    stop = stop or threading.Event()
    while rate is None and not stop.is_set():
        status = ask_one(session, robot_id, keys.STATUS)
        if (
            isinstance(status, dict)
            and isinstance(status.get("rate"), (int, float))
            and not isinstance(status["rate"], bool)
            and 30.0 <= status["rate"] <= 1000.0
        ):
            return float(status["rate"])
        if time.monotonic() > deadline:
            raise TimeoutError(
                f"robot '{robot_id}' did not give its tick rate within {wait:g} s: is its engine "
                f"running with --zenoh --robot-id {robot_id}, and reachable (see `nutty fleet list`)? "
                "(or give --rate)"
            )
        if not told:
            log(f"nutty bridge: waiting for robot '{robot_id}' on Zenoh ({keys.key(robot_id, keys.STATUS)})")
            told = True
        stop.wait(0.5)
    return float(rate or 0.0)


class FrameFollower:
    """The frames of one running engine, and nobody else's (see `follow_frames`)."""

    def __init__(
        self, session: Any, robot_id: str, receive: Callable[..., None], reject: Callable[..., None]
    ):
        self.key = keys.key(robot_id, keys.FRAMES)
        self.receive, self.reject = receive, reject
        self.live: set[str] = set()  # session ids whose liveliness token is alive now
        self._lock = threading.Lock()
        self._prefix = keys.session_key(robot_id, "")
        # history=True: tokens declared before this subscriber count too.
        self._tokens = session.liveliness().declare_subscriber(
            keys.session_key(robot_id), self._on_token, history=True
        )
        self._frames = session.declare_subscriber(self.key, self._on_sample)

    def _on_token(self, sample: Any) -> None:
        import zenoh  # Zenoh's native library loads only when Zenoh is used

        key = str(sample.key_expr)
        if not key.startswith(self._prefix):
            return
        sid = key[len(self._prefix) :]
        with self._lock:
            if sample.kind == zenoh.SampleKind.DELETE:
                self.live.discard(sid)
            else:
                self.live.add(sid)

    def _on_sample(self, sample: Any) -> None:
        if str(sample.key_expr) != self.key:  # a put on a wider key (nutty/**) reaches this subscriber too
            self.reject(f"a frame put on '{sample.key_expr}', not on {self.key}", "foreign")
            return
        sid = read_session(sample.attachment)
        with self._lock:
            live = set(self.live)
        if sid is None or sid not in live or len(live) != 1:
            why = (
                "a frame without an engine session id"
                if sid is None
                else f"a frame of session {sid}, while the running engine's is "
                f"{', '.join(sorted(live)) or 'none (no engine is alive)'}"
            )
            self.reject(why, "foreign")
            return
        try:
            doc, sent = frame_of(sample)
        except ValueError as exc:
            self.reject(str(exc))
            return
        self.receive(doc, sent, sid)

    def undeclare(self) -> None:
        for sub in (self._frames, self._tokens):
            try:
                sub.undeclare()
            except Exception:  # the session may be closing: the subscriber goes with it
                log.debug("undeclaring a frame follower's subscriber failed", exc_info=True)


def follow_frames(
    session: Any, robot_id: str, receive: Callable[..., None], reject: Callable[..., None]
) -> FrameFollower:
    """Follow the robot's frames: `receive(document, emission stamp, session id)` for each frame put on
    `nutty/<id>/frames` itself by the engine whose session liveliness token is alive (exactly one), and
    `reject(why, kind)` for anything else. Returns the follower (undeclare it when done)."""
    return FrameFollower(session, robot_id, receive, reject)
