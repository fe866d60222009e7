"""Ops of the idle sources (backend/engine/blocks/idle.py and the sine of blocks/core.py): what the kernel
steps of a breath, a noise, a sine and a weight shift, and the Python each keeps.

The breath's phase, the noise's cursor into its batch of draws and the weight shift's timing are arrays
of the blocks' states, which the kernel steps in place (the blocks' own ticks step the same arrays).
The noise's next batch of draws is Python's, after a run (`service`); a new weight shift's draws are
Python's before the op runs (`trap`): the kernel stops there and goes on once they are drawn.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.blocks.blink import Blink
from backend.engine.blocks.core import Sine
from backend.engine.blocks.idle import Breathe, Noise, WeightShift
from backend.engine.core import vm
from backend.engine.core.ops import SourceOp

if TYPE_CHECKING:
    from backend.engine.core.program import Refs


class BreatheOp(SourceOp[Breathe]):
    code = vm.BREATHE
    n_scalars = 5
    kernel_drives = {"amplitude": 1, "frequency": 3}
    pre_when = "wired"  # the kernel steps the phase (the block's one-element `state.phase`)

    def arrays(self) -> list[np.ndarray]:
        b = self.block
        return [b.offset_cycles, b.amp_values, b.amp_override, b.mask, b.state.phase]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        self._scalars(self.block.driven({}))

    def _scalars(self, d: Any) -> None:
        p, S, s = self.block.params, self.arena.S, self.s  # as Breathe.tick's compiled branch
        # (the kernel works the scale S[s] out of S[s + 1] and S[s + 4]: a compiled signal may drive the
        # amplitude in the kernel)
        S[s + 1] = float(d.amplitude)
        S[s + 2] = float(p.inhale_ratio)
        S[s + 3] = float(d.frequency)
        S[s + 4] = float(p.amplitude)

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)  # (`pre` runs only with a signal wired)
        if inputs is not None:
            self._scalars(self.block.driven(inputs))


class NoiseOp(SourceOp[Noise]):
    code = vm.NOISE
    n_scalars = 2
    pre_when = "wired"  # the kernel steps the draws' cursor; a new dt comes through `new_dt`

    def bind(self, refs: Refs) -> None:
        b = self.block
        st = b.state
        if st.y is st.x:  # as the block's compiled tick: the two stages in two arrays
            st.y = st.y.copy()
        b._transition(self.arena.dt or 1.0 / b.ctx.rate)  # (new parameters: new coefficients)
        if st.draws.exhausted():  # the kernel never draws: the batch it reads must hold this tick's draws
            st.draws.refill()
        super().bind(refs)
        self._scalars(b.params.amplitude)

    def arrays(self) -> list[np.ndarray]:
        b = self.block
        st = b.state
        return [st.x, st.y, b._coef_array, st.draws.batch, b.mask, st.draws.cursor]

    def stale(self) -> bool:
        b = self.block
        return super().stale() or b._coef_array is not self._coef

    def _scalars(self, amp: float) -> None:
        p, S, s = self.block.params, self.arena.S, self.s  # as Noise.tick's compiled branch
        S[s] = 1.0 if p.smoothing > 0.0 else 0.0
        S[s + 1] = float(amp * math.sqrt((p.tau + p.smoothing) / p.tau))

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)  # (`pre` runs only with a signal wired)
        if inputs is not None:
            self._scalars(self.block.driven(inputs).amplitude)

    def new_dt(self, dt: float) -> None:
        if dt > 0:
            self.block._transition(dt)
            self.rebind_if_stale()  # new coefficients: list them

    def service(self) -> None:
        draws = self.block.state.draws
        if draws.exhausted():
            draws.refill()

    def resume(self) -> None:
        self.service()  # the blocks' own ticks may have used up the batch

    def bound_extra(self) -> None:
        self._coef = self.block._coef_array


class SineOp(SourceOp[Sine]):
    """Sine has no kernel of its own: the op computes its wave with libm's sine, numpy's within 1 ulp."""

    code = vm.SINE
    n_scalars = 3
    needs_kernel = False
    # Python's part every tick: the phase is a float of the block's state

    def arrays(self) -> list[np.ndarray]:
        return [self.block.spread, self.block.mask]

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        b = self.block
        st, S, s = b.state, self.arena.S, self.s
        inputs = self.changed_inputs(results)
        if inputs is not None:
            d = b.driven(inputs)
            S[s] = float(d.offset)
            S[s + 1] = float(d.amplitude)
            self._frequency = d.frequency
        S[s + 2] = st.phi + b.params.phase
        st.phi = (st.phi + 2 * math.pi * self._frequency * dt) % (2 * math.pi)


class WeightShiftOp(SourceOp[WeightShift]):
    code = vm.OFFSET
    n_scalars = 3
    pre_when = "never"  # the kernel steps the timing; a new shift's draws (the block's numpy generator) are
    # Python's, through a `trap`

    def arrays(self) -> list[np.ndarray]:
        st = self.block.state
        return [st.start, st.target, st.offset, self.block.mask, st.timing]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        self.arena.S[self.s + 2] = float(self.block.params.shift_duration)

    def stale(self) -> bool:
        st = self.block.state
        return (
            super().stale()
            or st.start is not self._start
            or st.target is not self._target
            or st.offset is not self._offset
        )

    def bound_extra(self) -> None:
        st = self.block.state
        self._start, self._target, self._offset = st.start, st.target, st.offset

    def trap(self, dt: float, results: list[dict[str, Any]]) -> None:
        b = self.block  # WeightShift.tick up to its kernel
        self.arena.S[self.s] = b.advance(dt)
        self.arena.S[self.s + 1] = 1.0
        st = b.state
        if st.offset is st.start or st.offset is st.target:  # written in place: never one of its inputs
            st.offset = st.offset.copy()
        self.rebind_if_stale()


class BlinkOp(SourceOp[Blink]):
    """The blink's clock, envelope and frame in the kernel; Python's part: the inputs when they change
    (`pre`: hold, and whether the gaze shifted), a blink's start (`trap`: its draws) and `blinking` when
    it started or ended (`service`)."""

    code = vm.BLINK
    n_scalars = 8
    needs_kernel = False  # the block has no compiled tick: the op's arithmetic is Blink.tick's
    pre_when = "wired"

    def __init__(self, *args: Any):
        super().__init__(*args)
        self.result["blinking"] = False

    def arrays(self) -> list[np.ndarray]:
        b = self.block
        return [b.state.clock, b.delta, b.mask]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        p, S, s = self.block.params, self.arena.S, self.s
        S[s] = S[s + 1] = S[s + 2] = 0.0
        S[s + 3 : s + 7] = (p.close_time, p.hold_time, p.open_time, p.min_interval)
        self.resume()

    def resume(self) -> None:
        active = self.block.state.active  # (the blocks' own ticks may have started or ended a blink)
        self.arena.S[self.s + 7] = 1.0 if active else 0.0
        self.result["blinking"] = active

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)  # (`pre` runs only with a signal wired, when one ticked)
        if inputs is not None:  # as Blink.tick reads them; an unchanged gaze is no shift
            S, s = self.arena.S, self.s
            S[s] = 1.0 if inputs.get("hold") else 0.0
            S[s + 1] = 1.0 if self.block._gaze_shift(inputs.get("gaze")) else 0.0

    def trap(self, dt: float, results: list[dict[str, Any]]) -> None:
        S, s = self.arena.S, self.s
        self.block.schedule(dt, S[s] > 0.5, S[s + 1] > 0.5)
        S[s + 2] = 1.0

    def service(self) -> None:
        self.result["blinking"] = self.block.state.active
