"""The clip player's op: a playing clip's steady ticks in the kernel, every other tick the block's own.

A steady tick of a playing clip (the playhead moves on, passes no event, and the clip neither ends,
loops nor bounces, nor finishes its fade-out) runs in the kernel (compiled/clip_clock.py, then the
curves of compiled/curves.py's `clip_frame`) on the block's own state: its clock (`State.clock`:
playhead, envelope, crossfade), shown pose and masks, and the current clip's compiled curves. Every
other tick is the block's: the kernel stops before the op (`vm.TRAP`), Python runs `ClipPlayer.tick` on
the same state and its frame goes into the op's row, with its events and notes (a clip's start by
autoplay or a trigger's rising edge, its events, its end and the next queued play, a loop, a bounce,
the end of a fade-out). Commands (play, stop, seek) change the state at tick boundaries; the op binds
again when they replaced what it lists (`stale`), and reads the rest from the state's cells.

The `weight`, `playing` and `time` outputs change on every playing tick: they are worked out from the
state every tick only when a step reads them in Python (`outputs_read`: the kernel asks for `service`),
else when a probe asks (`refresh`, through `APU.signal_value`).
"""

from __future__ import annotations

from operator import is_not
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.blocks.clip_player import ClipPlayer, smooth_step
from backend.engine.compiled.clip_clock import MODE_CODES
from backend.engine.core import vm
from backend.engine.core.ops import NO_EVENTS, SourceOp

if TYPE_CHECKING:
    from backend.engine.core.program import Refs

_NONE_1 = np.zeros(1)  # listed in place of the arrays of a clip or warp there is none of (never read)
_NONE_2 = np.zeros((1, 1))
_NONE_3 = np.zeros((1, 1, 1))
_NONE_I1 = np.zeros(1, dtype=np.int64)
_NONE_I2 = np.zeros((1, 1), dtype=np.int64)
_NONE_B1 = np.zeros(1, dtype=bool)
_NO_TIMES = np.zeros(0)  # no event times (the kernel reads every one)
_NO_CLIP = (_NONE_2, _NONE_2, _NONE_3, _NONE_3, _NONE_I2, _NONE_I2, _NONE_I1, _NONE_I1, _NONE_B1, _NONE_B1,
            _NO_TIMES)  # fmt: skip


class ClipPlayerOp(SourceOp[ClipPlayer]):
    code = vm.CLIP
    n_scalars = 13
    pre_when = "inputs"  # a trigger or a speed wired from Python when one changed; the speed after a bind
    passes_events = True  # its own: the events of the ticks Python ran (`post`)
    kernel_drives = {"speed": 0}

    def __init__(self, *args: Any):
        super().__init__(*args)
        self.result.update(weight=0.0, playing=False, time=0.0)
        self._events: list[Any] = NO_EVENTS  # what the last tick Python ran gave out
        self._seen: tuple[Any, ...] = ()

    def arrays(self) -> list[np.ndarray]:
        st = self.block.state
        clip = st.current
        if clip is None:
            clip_arrays: tuple[np.ndarray, ...] = _NO_CLIP
        else:
            c = clip.curves
            clip_arrays = (c.t, c.v, c.h_right, c.h_left, c.code, c.mode, c.n_keys, clip.channels,
                           clip.relative, clip.enum_curves, clip.event_times)  # fmt: skip
        warp = st.warp if st.warp is not None else (_NONE_1, _NONE_1)
        scratch = clip.scratch if clip is not None else _NONE_1
        return [st.clock, st.values, st.from_values, st.mask, st.old_mask, *clip_arrays, *warp, scratch]

    def _listed(self) -> tuple[Any, ...]:
        """What the op's binding follows of the state: a new one of any of them binds again."""
        st = self.block.state
        return (
            st.current,
            st.warp,
            st.values,
            st.from_values,
            st.mask,
            st.old_mask,
            st.clock,
            st.speed,
            st.mode,
        )

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        self.sync()

    def bound_extra(self) -> None:
        self._seen = self._listed()

    def stale(self) -> bool:
        return super().stale() or any(map(is_not, self._listed(), self._seen))

    def drive_table(self) -> np.ndarray:
        table = super().drive_table()
        st = self.block.state  # a value not finite falls back on the play's speed, as ClipPlayer.tick
        for row, (port, _) in zip(table, self.drive_wires):
            if port == "speed":
                row[4] = self.block.drivables["speed"].resolve(None, st.speed or self.block.params.speed)
        return table

    def sync(self) -> None:
        """The scalars that follow the state's Python objects (the clip, its mode and warp, a start due)."""
        st, S, s = self.block.state, self.arena.S, self.s
        clip = st.current
        S[s + 1] = clip.duration if clip is not None else 0.0
        S[s + 2] = MODE_CODES.get(st.mode, 0.0)
        S[s + 3] = 0.0 if st.warp is None else 1.0
        S[s + 4] = 0.0 if clip is None else 1.0
        S[s + 5] = 1.0 if st.pending_autoplay else 0.0
        S[s + 7] = 1.0 if clip is not None and clip.any_relative else 0.0
        S[s + 8] = 1.0 if self.outputs_read else 0.0
        if clip is not None:  # the kernel writes the shown pose in place: the block's idle frame is stale
            self.block.__dict__.pop("_idle", None)

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)
        if inputs is None:
            return
        b, st, S, s = self.block, self.block.state, self.arena.S, self.s
        trigger = bool(inputs.get("trigger") or False)
        if trigger and not st.last_trigger and b.params.clip:
            S[s + 5] = 1.0  # a rising edge plays the clip: the block's own tick, which remembers the trigger
        else:
            st.last_trigger = trigger
        if not any(port == "speed" for port, _ in self.drive_wires):
            S[s] = b.driven(inputs, speed=st.speed or b.params.speed).speed

    def trap(self, dt: float, results: list[dict[str, Any]]) -> bool:
        """Run the block's own tick into the op's row (see the module doc); whether it gave out events."""
        inputs = {port: results[src].get(src_port) for port, src, src_port in self.input_wires}
        out = self.block.tick(dt, inputs)
        frame, a, S, s = out["out"], self.arena, self.arena.S, self.s
        a.V[self.out] = frame.values
        a.M[self.out] = frame.mask
        self._events = frame.events or NO_EVENTS
        self.result.update(weight=out["weight"], playing=out["playing"], time=out["time"])
        self.rebind_if_stale()
        self.sync()
        S[s + 6] = 1.0
        return bool(self._events)

    def post(self) -> None:
        self.frame.events, self._events = self._events, NO_EVENTS

    def service(self) -> None:
        self.refresh(None)

    def refresh(self, results: Any) -> None:
        """`weight`, `playing` and `time` as the block's tick gives them, from its state."""
        st = self.block.state
        r = self.result
        r["weight"], r["playing"], r["time"] = (
            smooth_step(st.env),
            st.current is not None and not st.done,
            st.pos,
        )

    def resume(self) -> None:
        self.rebind_if_stale()
        self.sync()
        self.refresh(None)
