"""The frames' recent events (speech, sounds, one-shot display changes), kept for clients that do not
read every frame: telemetry samples frames at its own rate, so an event on a frame it skips would be
lost. Each event is kept with the frame's `seq` and `t` (s, frame time) for `KEEP` seconds."""

from __future__ import annotations

import threading
from collections import deque
from typing import Any

from backend.engine.frames import AnimationFrame

KEEP = 2.0  # s of frame time an event stays in the list
MAX_EVENTS = 64


class RecentEvents:
    """A frame observer (`Engine.add_frame_observer`): a check of one list per frame, more only on a
    frame with events."""

    def __init__(self) -> None:
        self._events: deque[dict[str, Any]] = deque(maxlen=MAX_EVENTS)
        self._lock = threading.Lock()

    def observe(self, frame: AnimationFrame) -> None:
        if not frame.events:
            return
        with self._lock:
            for i, ev in enumerate(frame.events):
                self._events.append({"seq": frame.seq, "index": i, "t": round(frame.t, 6), **ev.to_dict()})

    def since(self, t: float) -> list[dict[str, Any]]:
        """The events of frames at or after `t` (s, frame time), oldest first."""
        with self._lock:
            return [e for e in self._events if e["t"] >= t - 1e-9]

    def recent(self, now: float, keep: float = KEEP) -> list[dict[str, Any]]:
        """The events of the last `keep` seconds before frame time `now`."""
        return self.since(now - keep)
