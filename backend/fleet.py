"""The fleet client: every Nutty engine on Zenoh, listed, watched and commanded from one place.

    from backend.fleet import Fleet
    with Fleet(connect=["tcp/192.168.1.20:7447"]) as fleet:
        fleet.robots()                          # ['museum-1', 'museum-2', 'museum-3'] (live ones)
        fleet["museum-1"].play("wave")          # one robot: NuttyClient's methods, over Zenoh
        fleet.group("museum-*").look_at(0.6, 0.2, 0.35)   # every robot the pattern matches
        fleet.send("museum-*", {"type": "set_led", "colour": [0, 1, 0]})
        for event in fleet.watch("museum-*", seconds=10): print(event)

`fleet[ID]` is a `FleetRobot`: the `NuttyClient` an AI already knows (`command`, `play`, `look_at`,
`say`, `set`, `cancel`, `status`, `robot`, `program`, ...), each call answered by that robot's engine
over Zenoh; errors raise `NuttyError` with the engine's code, message and field, as over REST.
`fleet.group(PATTERN)` has the same methods and returns `{robot id: result}`, with
`{"error": {...}}` for a robot that refused; a live robot that did not answer in time gets the
error `no_reply`. Patterns: `museum-*` (any run of characters), `*` (all).

Over Zenoh an engine takes the typed commands and answers `status`, `robot` and `program`; loading
programs and tuning parameters stay on its HTTP API (`not_on_zenoh`). The key layout is in
backend/zenoh_link/keys.py and docs/fleet.md.
"""

from __future__ import annotations

import contextlib
import queue
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from backend.client import NuttyClient, NuttyError
from backend.zenoh_link import keys
from backend.zenoh_link.codec import encode_json, frame_of, json_of
from backend.zenoh_link.session import ZenohOptions
from backend.zenoh_link.session import settle as wait_for_peers

DEFAULT_TIMEOUT = 5.0  # s to wait for answers

# REST calls NuttyClient makes -> what carries them over Zenoh (a query on a robot's key).
_READS = {"/api/status": keys.STATUS, "/api/robot": keys.ROBOT, "/api/program": keys.PROGRAM}


def _not_on_zenoh(method: str, path: str) -> NuttyError:
    return NuttyError(
        405,
        {
            "code": "not_on_zenoh",
            "message": f"{method} {path} is not available over Zenoh "
            "(commands, status, robot and program are): use the engine's HTTP API",
        },
    )


class Fleet:
    """A Zenoh session that sees every Nutty engine (see the module doc). Close it (or use `with`).

    `options` or the keywords (`connect`, `listen`, `mode`, `config`: as `--zenoh-*`) say how to join;
    `timeout`: seconds to wait for answers; `settle`: with no endpoint to connect to (multicast
    scouting only), how long to wait at start for a first peer.
    """

    def __init__(
        self,
        options: ZenohOptions | None = None,
        *,
        connect: Iterable[str] = (),
        listen: Iterable[str] = (),
        mode: str | None = None,
        config: str | None = None,
        timeout: float = DEFAULT_TIMEOUT,
        settle: float = 1.0,
    ):
        self.options = options or ZenohOptions(mode, list(connect), list(listen), config)
        self.timeout = float(timeout)
        self.session = self.options.open()
        wait_for_peers(self.session, self.options, settle)

    def close(self) -> None:
        self.session.close()

    def __enter__(self) -> Fleet:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # --- who is there -----------------------------------------------------------------------------
    def robots(self, pattern: str = "*", timeout: float | None = None) -> list[str]:
        """The live robots' ids (liveliness tokens) that `pattern` matches, sorted."""
        found = set()
        for reply in self.session.liveliness().get(
            keys.key(pattern, keys.ALIVE), timeout=timeout or self.timeout
        ):
            if reply.ok is not None and (rid := keys.robot_of(reply.ok.key_expr)) is not None:
                found.add(rid)
        return sorted(found)

    def wait_for(self, robots: Iterable[str] | int, pattern: str = "*", timeout: float = 30.0) -> list[str]:
        """Poll until the given ids (or that many robots) are live; the live ids. TimeoutError otherwise."""
        want = robots if isinstance(robots, int) else set(robots)
        deadline = time.monotonic() + timeout
        while True:
            live = self.robots(pattern, timeout=min(self.timeout, 2.0))
            if (len(live) >= want) if isinstance(want, int) else want <= set(live):
                return live
            if time.monotonic() > deadline:
                raise TimeoutError(f"after {timeout:g} s the live robots are {live}, waiting for {want}")
            time.sleep(0.2)

    def robot(self, robot_id: str) -> FleetRobot:
        return FleetRobot(self, robot_id)

    __getitem__ = robot

    def group(self, pattern: str) -> FleetGroup:
        return FleetGroup(self, pattern)

    # --- asking -----------------------------------------------------------------------------------
    def ask(
        self, target: str, leaf: str, payload: bytes | None = None, timeout: float | None = None
    ) -> dict[str, Any]:
        """Query `nutty/<target>/<leaf>`: {robot id: its JSON answer}. Robots that are live but did not
        answer within the timeout get a `no_reply` error; an exact id that is not live, `not_found`."""
        import zenoh  # native: loaded where Zenoh is used

        timeout = timeout or self.timeout
        answers: dict[str, Any] = {}
        replies = self.session.get(
            keys.key(target, leaf),
            payload=payload,
            timeout=timeout,
            target=zenoh.QueryTarget.ALL,
            consolidation=zenoh.ConsolidationMode.NONE,  # every robot's reply, none merged
        )
        for reply in replies:
            sample = reply.ok
            rid = keys.robot_of(sample.key_expr) if sample is not None else None
            if rid is None or not keys.matches(target, rid):
                continue  # an error reply carries no key, so no robot: the live check below covers it
            try:
                answers[rid] = json_of(sample)
            except ValueError as exc:
                answers[rid] = _error(
                    502, "bad_reply", f"robot '{rid}' answered something that is not JSON: {exc}"
                )
        if "*" in target or target not in answers:
            for rid in self.robots(target, timeout=min(timeout, 2.0)):
                answers.setdefault(
                    rid,
                    _error(504, "no_reply", f"robot '{rid}' is live but did not answer within {timeout:g} s"),
                )
        if "*" not in target and target not in answers:
            answers[target] = _error(404, "not_found", f"no live robot '{target}' (see `nutty fleet list`)")
        return answers

    def send(self, target: str, command: dict[str, Any], timeout: float | None = None) -> dict[str, Any]:
        """Send one command (the REST union: `{"type": ..., ...}`) to a robot or a pattern; the acks and
        errors by robot id (the /ws/control shapes). Without an `id`, one is chosen, the same for every
        robot, so its events can be followed on each."""
        if not isinstance(command, dict):
            raise TypeError("a command is a dict (JSON object) with a 'type'")
        if not isinstance(command.get("id"), str):
            command = {**command, "id": uuid.uuid4().hex[:12]}
        return self.ask(target, keys.COMMANDS, encode_json(command), timeout)

    def status(self, target: str = "*") -> dict[str, Any]:
        """Every matching robot's status (`GET /api/status` plus `robot_id` and Zenoh counters)."""
        return self.ask(target, keys.STATUS)

    # --- listening --------------------------------------------------------------------------------
    def watch(
        self, target: str = "*", *, seconds: float | None = None, status: bool = False, presence: bool = True
    ) -> Watch:
        """Follow events (and, with `status`, the 1 Hz status) of matching robots; see `Watch`."""
        return Watch(self, target, seconds=seconds, status=status, presence=presence)

    def frames(self, target: str, callback: Callable[[str, dict[str, Any], float | None], None]) -> Any:
        """Call `callback(robot id, frame document, emission time or None)` for every frame of the matching
        robots (on Zenoh's thread: keep it quick). Returns the subscriber: `undeclare()` it when done."""

        def on_sample(sample: Any) -> None:
            rid = keys.robot_of(sample.key_expr)
            try:
                doc, sent = frame_of(sample)
            except ValueError:  # not a frame document: nothing a frame callback could use
                return
            if rid is not None:
                callback(rid, doc, sent)

        return self.session.declare_subscriber(keys.key(target, keys.FRAMES), on_sample)

    # --- NuttyClient calls, carried over Zenoh -----------------------------------------------------
    def call(self, target: str, method: str, path: str, body: Any = None) -> dict[str, Any]:
        """A REST call of NuttyClient's as Zenoh carries it: {robot id: answer or error}."""
        if method == "POST" and path == "/api/commands":
            answers = self.send(target, dict(body or {}))
            return {rid: _ack_as_rest(a) for rid, a in answers.items()}
        if method == "DELETE" and path.startswith("/api/commands/"):
            answers = self.send(target, {"type": "cancel", "target": path.rsplit("/", 1)[-1]})
            return {rid: _cancel_as_rest(a) for rid, a in answers.items()}
        if method == "GET" and path in _READS:
            return self.ask(target, _READS[path])
        raise _not_on_zenoh(method, path)


def _error(status: int, code: str, message: str) -> dict[str, Any]:
    return {"type": "error", "status": status, "code": code, "message": message}


def is_error(answer: Any) -> bool:
    return isinstance(answer, dict) and answer.get("type") == "error"


def _ack_as_rest(answer: dict[str, Any]) -> dict[str, Any]:
    """An ack as `POST /api/commands` returns it ({id, status, result}); errors stay as they are."""
    return answer if is_error(answer) else {k: v for k, v in answer.items() if k != "type"}


def _cancel_as_rest(answer: dict[str, Any]) -> dict[str, Any]:
    """The cancel command's ack as `DELETE /api/commands/{id}` returns it ({id, status})."""
    if is_error(answer):
        return answer
    result = answer.get("result") or {}
    return {"id": result.get("target"), "status": result.get("status")}


def as_nutty_error(answer: dict[str, Any]) -> NuttyError:
    detail = {k: v for k, v in answer.items() if k not in ("type", "status")}
    return NuttyError(int(answer.get("status") or 500), detail)


class _OverZenoh(NuttyClient):
    """NuttyClient's methods carried by a Fleet's Zenoh session: no HTTP client to make or close."""

    def close(self) -> None:
        pass  # the fleet owns the session

    def _waiting(self, seconds: float) -> dict[str, Any]:
        return {}  # no HTTP timeouts; tool calls are not carried over Zenoh (they answer not_on_zenoh)


class FleetRobot(_OverZenoh):
    """One robot of a fleet with NuttyClient's methods; each call goes over Zenoh to that robot's engine.

    Errors raise `NuttyError` (status, code, message, field as over REST). There is no HTTP
    connection: `close()` does nothing, the fleet owns the session.
    """

    def __init__(self, fleet: Fleet, robot_id: str):  # no NuttyClient.__init__: no HTTP client to make
        self.fleet = fleet
        self.robot_id = keys.check_robot_id(robot_id)

    def _call(self, method: str, path: str, **kw: Any) -> Any:
        answer = self.fleet.call(self.robot_id, method, path, kw.get("json"))[self.robot_id]
        if is_error(answer):
            raise as_nutty_error(answer)
        return answer


class FleetGroup(_OverZenoh):
    """Every robot a pattern matches, with NuttyClient's methods: each returns {robot id: result}, and
    `{"error": {status, code, message, ...}}` for a robot that refused or did not answer."""

    def __init__(self, fleet: Fleet, pattern: str):
        self.fleet = fleet
        self.pattern = keys.check_pattern(pattern)

    def _call(self, method: str, path: str, **kw: Any) -> Any:
        answers = self.fleet.call(self.pattern, method, path, kw.get("json"))
        return {
            rid: ({"error": {k: v for k, v in a.items() if k != "type"}} if is_error(a) else a)
            for rid, a in sorted(answers.items())
        }


class Watch:
    """Events of matching robots as dicts with their `robot` id, in arrival order (iterate, or `get`):

    - the engines' events, acks and errors (the /ws/control shapes);
    - `{"type": "robot", "event": "appeared"|"vanished", "robot": id}` as liveliness tokens come and go
      (robots already live at the start appear first), unless `presence=False`;
    - with `status=True`, `{"type": "status", "robot": id, ...}` every second.

    Iteration ends after `seconds` (None: never) or `close()`.
    """

    def __init__(
        self,
        fleet: Fleet,
        target: str,
        *,
        seconds: float | None = None,
        status: bool = False,
        presence: bool = True,
    ):
        self.deadline = None if seconds is None else time.monotonic() + seconds
        self._queue: queue.Queue = queue.Queue(maxsize=10_000)
        self._closed = False
        s = fleet.session
        self._subs = [s.declare_subscriber(keys.key(target, keys.EVENTS), self._on_message)]
        if status:
            self._subs.append(s.declare_subscriber(keys.key(target, keys.STATUS), self._on_status))
        if presence:
            self._subs.append(
                s.liveliness().declare_subscriber(
                    keys.key(target, keys.ALIVE), self._on_presence, history=True
                )
            )

    def _put(self, item: dict[str, Any]) -> None:
        with contextlib.suppress(queue.Full):  # nobody reads: drop rather than grow
            self._queue.put_nowait(item)

    def _on_message(self, sample: Any, kind: str | None = None) -> None:
        try:
            message = json_of(sample)
        except ValueError:  # not JSON: a watcher reads JSON objects only
            return
        if isinstance(message, dict):
            head = {"type": kind} if kind else {}
            self._put({**head, "robot": keys.robot_of(sample.key_expr), **message})

    def _on_status(self, sample: Any) -> None:
        self._on_message(sample, "status")

    def _on_presence(self, sample: Any) -> None:
        import zenoh  # native: loaded where Zenoh is used

        event = "appeared" if sample.kind == zenoh.SampleKind.PUT else "vanished"
        self._put({"type": "robot", "event": event, "robot": keys.robot_of(sample.key_expr)})

    def get(self, timeout: float | None = None) -> dict[str, Any] | None:
        """The next item within `timeout` s (and before the watch's end), or None."""
        if self.deadline is not None:
            left = self.deadline - time.monotonic()
            timeout = left if timeout is None else min(timeout, left)
            if timeout <= 0:
                return None
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def __iter__(self) -> Iterator[dict[str, Any]]:
        while not self._closed and (self.deadline is None or time.monotonic() < self.deadline):
            item = self.get(timeout=0.25)
            if item is not None:
                yield item

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            for sub in self._subs:
                with contextlib.suppress(Exception):  # a session closing under us undeclared it already
                    sub.undeclare()

    def __enter__(self) -> Watch:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
