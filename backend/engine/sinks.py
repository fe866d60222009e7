"""Sinks: the consumers of Animation Frames (drivers, recorders, WebSocket hubs), each fed through its
own bounded queue and thread, so a slow sink drops frames (counted) and never stalls the engine's clock.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Generic, TypeVar

from backend.engine import clock_cpu
from backend.logs import Throttle

log = logging.getLogger(__name__)
_sink_faults = Throttle(every=10.0)  # a broken driver fails on every frame: its log line, once per 10 s


Item = TypeVar("Item")


class Sink(Generic[Item]):
    """A consumer of Animation Frames (a driver, a recorder, a WebSocket hub), or of other items a
    thread must hand over without waiting (`Item`: what `offer` takes and `consume` gets).

    `offer` never blocks: frames go through a bounded queue to the sink's own thread; when the queue
    is full the oldest frame is dropped and counted. Subclass and override `consume`, or pass a callable.
    `decimate = k` forwards every k-th frame only.

    The hand-over shares no lock with the sink's thread: the clock appends to the queue (atomic) and
    releases a "frames waiting" signal (releasing a lock never blocks), so a busy sink can never make
    the clock wait for it, not even for the interpreter lock a blocked lock acquisition gives away.
    """

    def __init__(
        self,
        name: str,
        consume: Callable[[Item], None] | None = None,
        max_queue: int = 8,
        decimate: int = 1,
        batch: float = 0.0,
    ):
        self.name = name
        self._consume = consume
        self.decimate = max(1, int(decimate))
        self.batch = max(0.0, float(batch))
        self._queue: deque[Item] = deque(maxlen=max_queue)
        self._signal = threading.Lock()  # locked: nothing new since the sink last looked
        self._signal.acquire()
        self._closed = False
        self.offered = self.delivered = self.errors = 0
        self._enqueued = self._taken = 0  # frames put in the queue (clock) / taken out of it (sink thread)
        self.last_error: str | None = None
        self._thread = threading.Thread(target=self._loop, name=f"sink-{name}", daemon=True)
        self._thread.start()

    @property
    def dropped(self) -> int:
        """Frames the queue dropped (oldest first) because the sink was behind."""
        return max(0, self._enqueued - self._taken - len(self._queue))

    def consume(self, frame: Item) -> None:
        if self._consume is not None:
            self._consume(frame)

    def offer(self, frame: Item) -> None:
        self.offered += 1
        if (self.offered - 1) % self.decimate:
            return
        self._queue.append(frame)  # deque(maxlen) drops the oldest for us
        self._enqueued += 1
        self._wake()

    def _wake(self) -> None:
        # try/except, not contextlib.suppress: this runs on the clock's thread for every frame and sink,
        # and the exception is the common case, where suppress costs more (benchmarks/bench_design.py)
        try:  # noqa: SIM105 (suppress is slower here: see the comment above)
            self._signal.release()
        except RuntimeError:  # already signalled: the sink will look anyway
            pass

    def _loop(self) -> None:
        clock_cpu.leave()  # a sink added on the clock thread (a swap's) must not run on the clock's CPU
        while True:
            self._signal.acquire()
            while True:
                try:
                    frame = self._queue.popleft()
                except IndexError:
                    break
                self._taken += 1
                try:
                    self.consume(frame)
                    self.delivered += 1
                except Exception as exc:  # a broken driver must not take the engine down
                    self.errors += 1
                    self.last_error = f"{type(exc).__name__}: {exc}"
                    skipped = _sink_faults.due(f"{self.name}: {type(exc).__name__}")
                    if skipped is not None:
                        again = f" ({skipped} more of its kind since the last report)" if skipped else ""
                        log.error(
                            "sink %r failed on a frame: %s%s", self.name, self.last_error, again, exc_info=exc
                        )
            if self._closed and not self._queue:
                return
            if self.batch and not self._closed:
                time.sleep(self.batch)

    def close(self, timeout: float = 2.0) -> None:
        """Deliver what is queued, then stop the sink's thread."""
        self._closed = True
        self._wake()
        self._thread.join(timeout)

    def stats(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "offered": self.offered,
            "delivered": self.delivered,
            "dropped": self.dropped,
            "errors": self.errors,
            "last_error": self.last_error,
            "decimate": self.decimate,
        }
