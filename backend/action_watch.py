"""What became of each long action, read from the frames the robot got: a block saying its clip or move
is done is not the robot being done, and an action the safety net had to correct should say so.

`ActionWatch` observes every frame on the clock thread (`Engine.add_frame_observer`: a check of two
dicts when no action runs, a few vector operations while one does), so a completion is as
deterministic as the frames themselves. For every long
action between its `started` and its terminal event it tallies the safety net's corrections: on how
many ticks, per DoF, and the largest |requested - delivered| (rad or m). When an action's block
reports `completed`, the event is held until the motion has ended: until what the robot gets moves as
the program's first stage asks, i.e. the second stage (the motion filter) and the net have caught up
(|d delivered - d stage-1| / dt below `SETTLE_SPEED` on every continuous channel the action moved, as
its block names them, for `SETTLE_TICKS` ticks), or at most `SETTLE_MAX` s. The event then goes out with `outcome`:

    {"reached": look_at's arrival or None, "settled": bool, "settle_time": s, "safety": {"corrected_ticks": n, "dofs": {dof: {"ticks": n,
     "max_correction": rad}}}}

and the same `outcome` is kept on the command's log entry. Cancelled and failed actions get their
tally at once (nothing is held).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame

# rad/s (or m/s): the delivered motion tracks the program's to within this. Idle motion (breathing, ears)
# on the same channels lags by up to ~0.06 rad/s under the motion filter, which must not hold an action
SETTLE_SPEED = 0.1
log = logging.getLogger(__name__)
SETTLE_TICKS = 5  # consecutive ticks within SETTLE_SPEED
SETTLE_MAX = 2.0  # s: a completion is never held longer


class _Tally:
    """One action's corrections, per channel (structure of arrays: a corrected tick is two vector ops)."""

    def __init__(self, n_channels: int):
        self.ticks = 0
        self.per_channel = np.zeros(n_channels, dtype=np.int64)  # ticks corrected
        self.largest = np.zeros(n_channels)  # largest |requested - delivered| (rad or m)

    def add(self, channels: np.ndarray, sizes: np.ndarray) -> None:
        self.ticks += 1
        self.per_channel[channels] += 1  # `channels` holds each channel once (np.flatnonzero)
        self.largest[channels] = np.maximum(self.largest[channels], sizes)


@dataclass
class _Held:
    message: dict[str, Any]
    channels: np.ndarray  # the continuous channels the action moved
    since: float | None = None  # engine time of the first frame seen after the completion
    calm: int = 0


class ActionWatch:
    """See the module doc. `release(cid, message)` is called (on the clock thread) with each held
    completion, its `outcome` filled in."""

    def __init__(self, embodiment: Embodiment, release: Callable[[str, dict[str, Any]], None]):
        self._release = release
        self._channel_dof = [embodiment.dofs[i].name for i in embodiment.dof_of_channel.tolist()]
        self._continuous = np.asarray(embodiment.continuous_mask, dtype=bool)
        self._n = embodiment.n_channels
        self._lock = threading.Lock()
        self._open: dict[str, _Tally] = {}
        self._held: dict[str, _Held] = {}
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # (delivered, stage-1) of the last frame

    # --- from the event path (any thread) ---------------------------------------------------------
    def opened(self, cid: str) -> None:
        with self._lock:
            self._open.setdefault(cid, _Tally(self._n))

    def hold(self, cid: str, message: dict[str, Any]) -> None:
        """Keep a `completed` event until the motion has ended (see the module doc): the motion of the
        channels its block names (`_channels`); with none (a sound), it goes out at once."""
        channels = np.asarray(message.get("_channels") or (), dtype=np.intp)
        channels = channels[self._continuous[channels]] if channels.size else channels
        with self._lock:
            if channels.size:
                self._open.setdefault(cid, _Tally(self._n))
                self._held[cid] = _Held(message, channels)
                return
            tally = self._open.pop(cid, None)
        outcome = {"reached": message.get("reached"), "settled": True, "settle_time": 0.0}
        self._release(cid, {**message, "outcome": {**outcome, "safety": self._safety(tally)}})

    def closed(self, cid: str) -> dict[str, Any]:
        """The outcome of an action that ended without a completion to hold (cancelled, failed)."""
        with self._lock:
            self._held.pop(cid, None)
            tally = self._open.pop(cid, None)
            return {"reached": None, "settled": None, "settle_time": None, "safety": self._safety(tally)}

    # --- the clock thread ---------------------------------------------------------------------------
    def observe(self, frame: AnimationFrame) -> None:
        try:
            self._observe(frame)
        except Exception:  # never the clock's problem: the action keeps its block's own events
            log.exception("watching the actions failed on frame %d", frame.seq)

    def _observe(self, frame: AnimationFrame) -> None:
        if not self._open and not self._held:  # (most frames) nothing watched: no lock taken
            # A concurrent `opened` or `hold` is seen on the next frame, as it would be had it come
            # just after this one; `_last` is the clock thread's alone.
            self._last = None
            return
        with self._lock:
            if not self._open and not self._held:
                self._last = None
                return
            if frame.corrected is not None and self._open:
                requested = frame.requested if frame.requested is not None else frame.program
                channels = np.flatnonzero(frame.corrected)
                sizes = (
                    np.abs(requested[channels] - frame.position[channels])
                    if requested is not None
                    else np.zeros(channels.size)
                )
                for tally in self._open.values():
                    tally.add(channels, sizes)
            done = self._settle(frame) if self._held else []
        for cid, message in done:
            self._release(cid, message)

    def _settle(self, frame: AnimationFrame) -> list[tuple[str, dict[str, Any]]]:
        stage1 = frame.stage1 if frame.stage1 is not None else frame.position
        last, self._last = self._last, (frame.position.copy(), stage1.copy())
        if last is None:
            return []
        lag = np.abs((frame.position - last[0]) - (stage1 - last[1])) / frame.dt
        done = []
        for cid, held in list(self._held.items()):
            held.since = frame.t if held.since is None else held.since
            held.calm = held.calm + 1 if float(lag[held.channels].max()) < SETTLE_SPEED else 0
            waited = frame.t - held.since
            if held.calm >= SETTLE_TICKS or waited >= SETTLE_MAX:
                del self._held[cid]
                outcome = {
                    "reached": held.message.get("reached"),
                    "settled": held.calm >= SETTLE_TICKS,
                    "settle_time": round(waited, 4),
                    "safety": self._safety(self._open.pop(cid, None)),
                }
                done.append((cid, {**held.message, "outcome": outcome}))
        return done

    def _safety(self, tally: _Tally | None) -> dict[str, Any]:
        if tally is None:
            return {"corrected_ticks": 0, "dofs": {}}
        dofs: dict[str, dict[str, Any]] = {}
        for c in np.flatnonzero(tally.per_channel).tolist():  # once per action, when it ends
            name, ticks, size = self._channel_dof[c], int(tally.per_channel[c]), float(tally.largest[c])
            entry = dofs.setdefault(name, {"ticks": 0, "max_correction": 0.0})
            entry["ticks"] = max(entry["ticks"], ticks)
            entry["max_correction"] = round(max(entry["max_correction"], size), 6)
        return {"corrected_ticks": tally.ticks, "dofs": dofs}
