"""Work handed to the engine's clock thread: a queue of calls run at the next tick boundary, each
answering through its Future (`Engine.call_soon`, `Engine.call`)."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from queue import Empty, SimpleQueue
from typing import Any


@dataclass
class Pending:
    fn: Callable[[], Any]
    future: Future


def drain(pending: SimpleQueue[Pending]) -> None:
    """Run every queued call (the caller holds the engine's tick lock: nobody else takes items)."""
    while not pending.empty():
        try:
            item = pending.get_nowait()
        except Empty:
            return
        if not item.future.set_running_or_notify_cancel():
            continue
        try:
            item.future.set_result(item.fn())
        except BaseException as exc:  # noqa: BLE001 (not swallowed: the caller's future re-raises it)
            item.future.set_exception(exc)
