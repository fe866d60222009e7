"""Sinks: the consumers of Animation Frames (drivers, recorders, WebSocket hubs), each fed through its
own bounded queue and thread, so a slow sink drops frames (counted) and never stalls the engine's clock.

The engine's clock hands each frame to one `FanOut`, whose thread offers it to every sink: the clock
wakes one thread per tick however many sinks there are. Waking a sleeping thread costs the clock
7-8 µs a sink (a futex wake-up on the other CPU; 17-21 µs of a 140-210 µs tick with three sinks,
measured served at 100 Hz on a 2-core VM), and a frame reaches a sink's thread one hand-over later:
11-12 µs p50 per hand-over on the same machine.
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
        # frames put in the queue (clock) / taken out of it / done with, consumed or failed (sink thread)
        self._enqueued = self._taken = self._done = 0
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
            while self._queue:  # (only this thread takes frames out: one listed is still there to take)
                self._taken += 1  # before taking it: `idle()` never sees a frame in neither place
                frame = self._queue.popleft()
                try:  # (a broken driver must not take the engine down)
                    self.consume(frame)
                    self.delivered += 1
                except Exception as exc:  # noqa: BLE001 (logged, throttled, by failed())
                    self.failed(exc)
                finally:
                    self._done += 1
            if self._closed and not self._queue:
                return
            if self.batch and not self._closed:
                time.sleep(self.batch)

    def failed(self, exc: Exception, where: str = "") -> None:
        """Count an error of this sink (`where`: what in it failed, e.g. one of a fan-out's sinks) and log
        it, once per 10 s for each kind."""
        self.errors += 1
        self.last_error = f"{where}{type(exc).__name__}: {exc}"
        skipped = _sink_faults.due(f"{self.name}: {where}{type(exc).__name__}")
        if skipped is not None:
            again = f" ({skipped} more of its kind since the last report)" if skipped else ""
            log.error("sink %r failed on a frame: %s%s", self.name, self.last_error, again, exc_info=exc)

    def idle(self) -> bool:
        """Whether every frame offered so far has been consumed (or dropped) and none is being consumed."""
        return self._done >= self._taken + len(self._queue)

    def close(self, timeout: float = 2.0) -> None:
        """Deliver what is queued, then stop the sink's thread."""
        self._closed = True
        self._wake()
        self._thread.join(timeout)

    def on_own_thread(self) -> bool:
        """Whether the caller is this sink's thread (inside `consume`)."""
        return threading.current_thread() is self._thread

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


#: Frames the fan-out holds while its thread is held off (4 s at 1000 Hz), older ones dropped: enough that a
#: headless run's burst of ticks (a recording) reaches its sinks whole, as each sink's own queue allows.
FAN_OUT_QUEUE = 4096
#: Longest wait (s) for the fan-out to hand over the frames made so far (a flush before a sink leaves).
FLUSH_TIMEOUT = 0.5


class FanOut(Sink[Item]):
    """The clock's single hand-over per tick: its thread offers each frame to every sink `sinks()` lists
    at that moment, in order. A frame the fan-out drops (its thread held off for FAN_OUT_QUEUE frames)
    reaches no sink, and is counted in its own `dropped`."""

    def __init__(self, sinks: Callable[[], list[Sink[Item]]], max_queue: int = FAN_OUT_QUEUE):
        self._sinks = sinks
        super().__init__("fan-out", max_queue=max_queue)

    def consume(self, frame: Item) -> None:
        for sink in self._sinks():
            try:  # (a sink whose own `offer` is broken: the others still get the frame)
                sink.offer(frame)
            except Exception as exc:  # noqa: BLE001 (logged, throttled, by failed())
                self.failed(exc, f"{sink.name}: ")

    def flush(self, timeout: float = FLUSH_TIMEOUT) -> bool:
        """Wait until every frame offered so far has been handed to the sinks; whether it was in time.
        Returns at once on the fan-out's own thread (a sink removed from inside a hand-over)."""
        if self.on_own_thread():
            return self.idle()
        deadline = time.monotonic() + timeout
        while not self.idle():
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.0005)
        return True
