"""The ops of the signal blocks the core runs in the kernel: the emotion mapper and scalar math.

A signal op has no frame. Its outputs are scalar slots, which the kernel carries into the parameters of
the compiled blocks it drives (`Op.kernel_drives`, compiled/signals.py's `drive`), so a moving emotion
costs neither a Python tick nor a `pre` of the blocks it drives. Python readers (a clip player's speed, a
probe) read the op's `result`, a dict like the block's own tick returns, made again only when an output
changed (the kernel flags that, `CH`): an unchanged output stays the same object, which tells quiet
blocks downstream at once that nothing changed.

The block's state stays the block's: the op steps a copy in the kernel (`x`, floats and a posture index
where the block keeps a name), writes it back whenever it publishes the outputs (`publish`: every output
is a function of the state, so the state moved only then) or gets new parameters (`bind`), and reads it
again after the block's own tick ran (`resume`) or the block got a new state (`bind`). The core compiles
a signal block only when every compiled block it feeds takes the signal in the kernel
(`compiles_signal`); otherwise it ticks in Python as before.

When no step reads the outputs in Python (every reader takes them in the kernel: the interactive
program's emotion and breath amplitude), a change is published only when something asks (`refresh`: a
probe, a trap, the blocks' own ticks, a swap's adoption), not on every tick the signal moves (`lazy`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from backend.engine.blocks.signals import Emotion, Math
from backend.engine.compiled.signals import MATH_OPS
from backend.engine.core import vm
from backend.engine.core.ops import B, Op

if TYPE_CHECKING:
    from backend.engine.core.program import Refs


class SignalOp(Op[B]):
    """An op whose outputs are scalar slots (see the module doc)."""

    frame_inputs = ()
    needs_kernel = False
    passes_events = False
    output_slots: ClassVar[dict[str, int]] = {}  # output port -> its slot (after `s`)
    published_from: ClassVar[int] = 0  # the first output slot, and how many the kernel compares
    n_published: ClassVar[int] = 0
    lazy_slot: ClassVar[int] = 0  # the slot saying no step reads the outputs in Python (vm.EMOTION_LAZY, …)

    def __init__(self, *args: Any):
        super().__init__(*args)
        self.result = {}

    def slot(self, port: str) -> int:
        return self.s + self.output_slots[port]

    def bind(self, refs: Refs) -> None:
        if self._state is not None and self._state is self.block.state:
            self.write_state()  # (new parameters) the kernel stepped the state since: it is the block's
        self.prepare()
        self.read_state()
        super().bind(refs)
        self.constants()
        self.unpublish()
        self.arena.S[self.s + self.lazy_slot] = 0.0 if self.outputs_read else 1.0

    def refresh(self, results: list[dict[str, Any]]) -> None:
        """Publish the outputs the kernel flagged changed (a lazy op's, for a probe, a trap or the blocks'
        own ticks; `publish` also writes the block's state back)."""
        if self.arena.CH[self.out]:
            self.arena.CH[self.out] = False
            self.publish(results)

    def unpublish(self) -> None:
        """Make the next kernel run publish its outputs (the last published copies as NaN: never the same)."""
        first = self.s + self.published_from + self.n_published
        self.arena.S[first : first + self.n_published] = math.nan

    def restore(self, results: list[dict[str, Any]]) -> None:
        """After the block's own ticks: its outputs are the block's last ones, its state the block's."""
        if results[self.step]:
            self.result = results[self.step]
        self.forget_inputs()
        self.resume()

    def resume(self) -> None:
        self.read_state()
        self.unpublish()

    def publish(self, results: list[dict[str, Any]]) -> None:
        """An output changed in the kernel: the outputs as the block's tick returns them in `results` and
        `result`, and what the kernel stepped back into the block's state (one call: it runs each tick the
        signal moves)."""

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)  # (`pre` runs only with a signal wired from Python)
        if inputs is not None:
            self.inputs(self.block.driven(inputs))

    # --- per block ------------------------------------------------------------------------------------
    def prepare(self) -> None:
        """Make the arrays the parameters set (at bind only: the table lists them)."""

    def read_state(self) -> None:
        """Copy the block's state into the arrays the kernel steps."""

    def write_state(self) -> None:
        """Copy the state the kernel stepped back into the block's (the memos of its own last tick no
        longer hold)."""

    def constants(self) -> None:
        """Write the scalars the kernel reads that only the parameters set (and the unwired inputs)."""

    def inputs(self, d: Any) -> None:
        """Write the driven inputs' scalars."""


class EmotionOp(SignalOp[Emotion]):
    code = vm.EMOTION
    n_scalars = vm.EMOTION_LAZY + 1
    lazy_slot = vm.EMOTION_LAZY
    kernel_drives = {"valence": 0, "arousal": 1}
    output_slots = {
        port: vm.EMOTION_OUT + i
        for i, port in enumerate(("speed", "amplitude", "posture_offset", "valence", "arousal"))
    }
    published_from, n_published = vm.EMOTION_OUT, vm.EMOTION_OUTPUTS

    def __init__(self, *args: Any):
        super().__init__(*args)
        self.x = np.zeros(4)  # valence, arousal, primed (0/1), posture index (-1: none)
        self._postures = np.zeros((1, 2))
        self._names: list[str] = []

    def arrays(self) -> list[np.ndarray]:
        return [self.x, self._postures]

    def prepare(self) -> None:
        p = self.block.params
        self._names = list(p.postures)
        self._postures = np.array([p.postures[n] for n in self._names], dtype=float).reshape(-1, 2)

    def read_state(self) -> None:
        st = self.block.state
        index = self._names.index(st.posture) if st.posture in self._names else -1
        self.x[:] = (st.v, st.a, 1.0 if st.primed else 0.0, index)

    def constants(self) -> None:
        p, S, s = self.block.params, self.arena.S, self.s
        S[s + 3 : s + 11] = (
            p.speed_min, p.speed_max, p.amplitude_min, p.amplitude_max, p.valence_amplitude, p.droop,
            p.arousal_lift, p.hysteresis,
        )  # fmt: skip
        self.new_dt(self.arena.dt or 1.0 / self.block.ctx.rate)
        self.inputs(self.block.driven({}))

    def new_dt(self, dt: float) -> None:
        smoothing = self.block.params.smoothing  # as Emotion.tick
        self.arena.S[self.s + 2] = 1.0 if smoothing <= 0.0 else 1.0 - math.exp(-dt / smoothing)

    def inputs(self, d: Any) -> None:
        self.arena.S[self.s], self.arena.S[self.s + 1] = d.valence, d.arousal

    def publish(self, results: list[dict[str, Any]]) -> None:
        o = self.s + vm.EMOTION_OUT
        speed, amplitude, offset, v, a, index = self.arena.S[o : o + vm.EMOTION_OUTPUTS].tolist()
        posture = self._names[int(index)]
        results[self.step] = self.result = {
            "speed": speed,
            "amplitude": amplitude,
            "posture_offset": offset,
            "valence": v,
            "arousal": a,
            "posture": posture,
        }
        self.write_state()

    def write_state(self) -> None:
        v, a, primed, index = self.x.tolist()
        if primed < 0.5:  # not yet stepped: the block's state is as it was read
            return
        b = self.block
        st = b.state
        st.v, st.a, st.primed = v, a, True
        if index >= 0:
            st.posture = self._names[int(index)]
        b.__dict__.pop("_last_out", None)  # the block's memos of its own last tick no longer hold
        b.__dict__.pop("_nearest_seen", None)


class MathOp(SignalOp[Math]):
    code = vm.MATH
    n_scalars = vm.MATH_LAZY + 1
    lazy_slot = vm.MATH_LAZY
    kernel_drives = {"a": 0, "b": 1}
    output_slots = {"value": vm.MATH_OUT}
    published_from, n_published = vm.MATH_OUT, 1

    def __init__(self, *args: Any):
        super().__init__(*args)
        self.last = np.zeros(1)  # the last finite output

    def arrays(self) -> list[np.ndarray]:
        return [self.last]

    def read_state(self) -> None:
        self.last[0] = self.block.state.last

    def constants(self) -> None:
        p, S, s = self.block.params, self.arena.S, self.s
        S[s + 2 : s + 10] = (
            MATH_OPS.index(p.op), p.in_min, p.in_max, p.out_min, p.out_max, 1.0 if p.clamped else 0.0, p.min,
            p.max,
        )  # fmt: skip
        self.inputs(self.block.driven({}))

    def inputs(self, d: Any) -> None:
        S, s = self.arena.S, self.s
        S[s], S[s + 1] = d.a, d.b

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)
        if inputs is None:
            return
        try:  # as Math.tick: inputs it cannot resolve give NaN, which holds the last finite output
            d = self.block.driven(inputs)
        except (OverflowError, TypeError, ValueError):
            self.arena.S[self.s : self.s + 2] = math.nan
            return
        self.inputs(d)

    def publish(self, results: list[dict[str, Any]]) -> None:
        results[self.step] = self.result = {"value": float(self.last[0])}
        self.write_state()

    def write_state(self) -> None:
        b = self.block
        b.state.last = float(self.last[0])
        b.__dict__.pop("_computed", None)  # the block's memo of its own last tick no longer holds


def output_slot(op: Op, port: str) -> int:
    """The scalar slot of a signal op's output `port`."""
    if not isinstance(op, SignalOp):
        raise TypeError(f"{type(op).__name__} has no scalar outputs")
    return op.slot(port)


def takes_in_kernel(src: Op | type[Op] | None, src_port: str, dst: Op | type[Op] | None, port: str) -> bool:
    """Whether the wire src.src_port -> dst.port runs in the kernel: a signal op's output into a parameter
    the reading op takes in the kernel."""
    src_cls = src if isinstance(src, type) or src is None else type(src)
    return (
        src_cls is not None
        and issubclass(src_cls, SignalOp)
        and src_port in src_cls.output_slots
        and dst is not None
        and port in dst.kernel_drives
    )


def compiles_signal(op: type[Op], readers: list[tuple[str, type[Op] | None, str]]) -> bool:
    """Whether a block with op `op` may run in the kernel, given what reads it: per wire out, its port,
    the reader's op (None: a Python block) and the reader's port. A signal op's every compiled reader
    must take it in the kernel (a `pre` reading it would run before the kernel wrote it)."""
    if not issubclass(op, SignalOp):
        return True
    return all(
        reader is None or takes_in_kernel(op, src_port, reader, port) for src_port, reader, port in readers
    )
