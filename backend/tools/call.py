"""Carrying out one tool call: check its arguments against the live vocabulary, turn it into its
command, run that through the server's one command path (`Hub.run_command`: the same validation, log,
events and safety net as every other command), and optionally wait until the action has ended.

The answer says what happened: `{"tool", "command", "id", "status", "result", "waited", "timed_out"}`,
`status` being the command's (`started`, `queued`, `completed`, `cancelled`, `failed`). Waiting listens
to the same event fan-out as /ws/control clients, so it ends the moment the terminal event goes out.
"""

from __future__ import annotations

import asyncio
import contextlib
import weakref
from collections.abc import Iterator
from typing import Any

from pydantic import BaseModel, ValidationError

from backend.control.ai import ToolArgumentError
from backend.hub import TERMINAL, Hub
from backend.tools.build import Tool, build_tools
from backend.tools.dialect_schemas import drop_nulls
from backend.tools.errors import ToolError
from backend.tools.idempotency import RequestLedger
from backend.tools.observe import frame_summary
from backend.tools.status import robot_status
from backend.tools.table import FrameArguments, StatusArguments, WaitOptions

OPEN = ("accepted", "queued", "started")  # a command that has not ended yet
_LEDGERS: weakref.WeakKeyDictionary[Hub, RequestLedger] = weakref.WeakKeyDictionary()  # one per server


async def call_tool(hub: Hub, name: str, arguments: Any) -> dict[str, Any]:
    """Carry out tool `name` with `arguments` on the Hub's session. Raises ToolError naming the field,
    or the HTTPException of `Hub.run_command` (the command's own error, naming its field)."""
    toolset = await asyncio.to_thread(build_tools, hub.session)
    tool = toolset.get(name)
    if tool is None:
        raise ToolError(
            f"no tool '{name}' for robot '{toolset.live.robot}' and program '{toolset.live.program}' "
            f"(tools: {[t.name for t in toolset.tools]})",
            field="name",
            code="unknown_tool",
            status=404,
        )
    if not isinstance(arguments, dict):
        raise ToolError("a tool's arguments are a JSON object", code="invalid_arguments")
    arguments = drop_nulls(arguments, tool.parameters)  # strict dialects send null for "not given"
    request_id = _request_id(arguments.pop("request_id", None))
    check_choices(tool, arguments)
    if tool.command is None:  # a read is always fresh: its request id is not replayed
        if tool.name == "get_frame":
            _validated(FrameArguments, arguments)
            frame = await asyncio.to_thread(frame_summary, hub.session, hub.session.engine.last_frame)
            return {"tool": "get_frame", **frame}
        return await _status(hub, _validated(StatusArguments, arguments))
    if request_id is None:
        return await _act(hub, tool, arguments, None)
    ledger = _LEDGERS.setdefault(hub, RequestLedger())
    what = {k: v for k, v in arguments.items() if k not in ("wait", "timeout")}  # a retry may wait otherwise
    answer, replayed = await ledger.once(
        request_id, name, what, lambda: _act(hub, tool, arguments, request_id)
    )
    return await _replay(hub, answer, arguments) if replayed else answer


async def _replay(hub: Hub, answer: dict[str, Any], arguments: dict[str, Any]) -> dict[str, Any]:
    """A repeated call's answer: the first one, with the action's status as it is now (waited for, when
    the repeat asks to wait and the action still runs)."""
    waiting = _validated(WaitOptions, {k: arguments[k] for k in ("wait", "timeout") if k in arguments})
    entry, timed_out = hub.commands.get(answer["id"]), False
    if waiting.wait and entry is not None and entry["status"] in OPEN:
        with listening(hub) as events:
            entry, timed_out = await wait_until_ended(hub, events, answer["id"], waiting.timeout)
    return {
        **answer,
        "status": entry["status"] if entry else answer["status"],
        "waited": answer["waited"] or waiting.wait,
        "timed_out": timed_out,
        "replayed": True,
        "outcome": entry.get("outcome") if entry else answer.get("outcome"),
    }


def _request_id(value: Any) -> str | None:
    if value is None or (isinstance(value, str) and 1 <= len(value) <= 128):
        return value
    raise ToolError("request_id: a string of 1 to 128 characters (e.g. a UUID)", field="request_id")


async def _act(hub: Hub, tool: Tool, arguments: dict[str, Any], request_id: str | None) -> dict[str, Any]:
    """Send the tool's command and, when asked, wait for the action to end; the call's answer."""
    args = dict(arguments)
    waiting = WaitOptions()
    if tool.long_action:
        waiting = _validated(WaitOptions, {k: args.pop(k) for k in ("wait", "timeout") if k in args})
    command = _command(tool, args)
    with listening(hub) as events:
        ack = await asyncio.to_thread(hub.run_command, command)
        entry, timed_out = hub.commands.get(ack["id"]), False
        if waiting.wait and ack["status"] in OPEN:
            entry, timed_out = await wait_until_ended(hub, events, ack["id"], waiting.timeout)
    return {
        "tool": tool.name,
        "command": command["type"],
        "id": ack["id"],
        "status": entry["status"] if entry else ack["status"],
        "result": ack["result"],
        "waited": waiting.wait and ack["status"] in OPEN,
        "timed_out": timed_out,
        "request_id": request_id,
        "replayed": False,
        "outcome": entry.get("outcome") if entry else None,
    }


def _command(tool: Tool, args: dict[str, Any]) -> dict[str, Any]:
    """The command a tool call sends: its declared route's, or the tool's command with the arguments."""
    if tool.spec.route is None:
        return {"type": tool.command, **args}
    try:
        return tool.spec.route(args)
    except ToolArgumentError as exc:
        raise ToolError(str(exc), field=exc.field) from exc


def check_choices(tool: Tool, arguments: dict[str, Any]) -> None:
    """Every argument with an enum in the tool's schema takes one of its values (a clip, a posture, ...);
    ToolError names the argument and lists what exists."""
    for name, prop in tool.parameters["properties"].items():
        allowed = prop.get("enum")
        if (
            allowed is not None
            and name in arguments
            and arguments[name] is not None
            and arguments[name] not in allowed
        ):
            raise ToolError(f"{name}: {arguments[name]!r} is not one of {allowed}", field=name)


def _validated(model: type[BaseModel], data: dict[str, Any]) -> Any:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        field = ".".join(str(x) for x in err["loc"]) or None
        raise ToolError(f"{field}: {err['msg']}" if field else err["msg"], field=field) from exc


@contextlib.contextmanager
def listening(hub: Hub) -> Iterator[asyncio.Queue]:
    """The Hub's command events, as a /ws/control client gets them, for as long as the block runs."""
    queue: asyncio.Queue = asyncio.Queue(maxsize=256)
    hub.control_queues.add(queue)
    try:
        yield queue
    finally:
        hub.control_queues.discard(queue)


async def wait_until_ended(hub: Hub, events: asyncio.Queue, cid: str, timeout: float) -> tuple[Any, bool]:
    """Wait (at most `timeout` s) until command `cid` has ended; its log entry, and whether time ran out.
    The log is the truth; each event only says it is worth looking again (so a dropped one costs nothing)."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while True:
        entry = hub.commands.get(cid)
        if entry is None or entry["status"] in TERMINAL:
            return entry, False
        remaining = deadline - loop.time()
        if remaining <= 0 or (hub.stopping is not None and hub.stopping.is_set()):
            return entry, True
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(events.get(), min(remaining, 1.0))


async def _status(hub: Hub, args: StatusArguments) -> dict[str, Any]:
    entry, timed_out = None, False
    if args.id is not None:
        entry = hub.commands.get(args.id)
        if entry is None:
            raise ToolError(
                f"id: no command with id '{args.id}'", field="id", code="unknown_command", status=404
            )
        if args.wait and entry["status"] in OPEN:
            with listening(hub) as events:
                entry, timed_out = await wait_until_ended(hub, events, args.id, args.timeout)
    status = await asyncio.to_thread(robot_status, hub.session)
    return {"tool": "get_status", **status, "command": dict(entry) if entry else None, "timed_out": timed_out}
