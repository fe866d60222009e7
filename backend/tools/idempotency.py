"""Idempotent tool calls: a tool call with a `request_id` is carried out once; a repeat of it within
`TTL` seconds (an agent retrying after its client timed out, a network hiccup) gets the first call's
answer again, marked `replayed`, with the command's status as it is now, and does not act again.

A repeat that arrives while the first is still being carried out (a waiting call) waits for that
answer. The same `request_id` with another tool or other arguments is refused (`request_id_reused`):
it is a client's bug, and guessing which call it meant could move the robot twice. Request ids are the
client's to choose (a UUID is the usual choice); they are kept in memory, at most `MAX_ENTRIES`.
"""

from __future__ import annotations

import asyncio
import json
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from backend.tools.errors import ToolError

TTL = 600.0  # s a request id is remembered
MAX_ENTRIES = 4096
REQUEST_ID_SCHEMA: dict[str, Any] = {
    "type": "string",
    "minLength": 1,
    "maxLength": 128,
    "description": "your id for this call (e.g. a UUID): a repeat with the same id within 10 minutes "
    "answers the first call's result again instead of acting twice (safe retries)",
}


@dataclass
class _Entry:
    at: float
    key: str  # the tool and its arguments, as canonical JSON
    answer: asyncio.Future


class RequestLedger:
    """The answers of recent tool calls by request id (see the module doc). Used on one event loop."""

    def __init__(
        self, ttl: float = TTL, max_entries: int = MAX_ENTRIES, clock: Callable[[], float] = time.monotonic
    ):
        self.ttl = ttl
        self.max_entries = max_entries
        self.clock = clock
        self._entries: OrderedDict[str, _Entry] = OrderedDict()

    def _forget_old(self, now: float) -> None:
        while self._entries:
            rid, entry = next(iter(self._entries.items()))
            if now - entry.at < self.ttl and len(self._entries) <= self.max_entries:
                return
            self._entries.pop(rid)

    async def once(
        self,
        request_id: str,
        tool: str,
        arguments: dict[str, Any],
        act: Callable[[], Awaitable[dict[str, Any]]],
    ) -> tuple[dict[str, Any], bool]:
        """(the answer, whether it is a replay): `act()` the first time `request_id` is seen within the
        TTL, the first answer after that. ToolError when the id came with another call, or when the
        first call failed (its error again: it did not act, so a retry may use a new id)."""
        now = self.clock()
        self._forget_old(now)
        key = json.dumps([tool, arguments], sort_keys=True, default=str)
        entry = self._entries.get(request_id)
        if entry is not None:
            if entry.key != key:
                raise ToolError(
                    f"request_id: '{request_id}' was used {now - entry.at:.0f} s ago for another call "
                    f"(another tool or other arguments); use a new id for a new call",
                    field="request_id",
                    code="request_id_reused",
                    status=409,
                )
            return dict(await asyncio.shield(entry.answer)), True
        future: asyncio.Future = asyncio.get_running_loop().create_future()
        self._entries[request_id] = _Entry(now, key, future)
        try:
            answer = await act()
        except BaseException as exc:
            self._entries.pop(request_id, None)  # a refused call did nothing: its id may be tried again
            if not future.done():
                future.set_exception(exc)
                future.exception()  # retrieved here, so an unawaited failure is not logged as lost
            raise
        future.set_result(answer)
        return answer, False
