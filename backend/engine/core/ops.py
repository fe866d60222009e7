"""How each compiled block type becomes a row of the core's op table (backend/engine/core/vm.py).

An op binds its block's arrays (state and derived constants) into the table, writes the scalars the
kernel reads (`pre`, in Python: the drivable parameters from wired signals, a gaze's target) and passes
the events along (`post`), which the kernel does not see. The block keeps its state: the kernel writes
into the block's own arrays, so the block's own tick (which the APU runs to time blocks one by one) and
the core step the same state. State the kernel steps itself lives in arrays for that reason (a breath's
phase, the cursor into a noise block's batch of draws), and an op whose kernel step needs Python
afterwards (drawing the noise's next batch) asks for its `service` through `run_ops`' return, or before
(a weight shift's next draws) stops the run for its `trap`. The idle sources' ops are in idle_ops.py, the
chains' in chain_ops.py, the LED's in display_ops.py, the signals' in signal_ops.py.

An op is bound again when its block may have replaced the arrays it listed: new parameters (a live
edit), a new state object (reset, a hot swap's adopted state) or, for the ops that say so, after their
`pre` changed the block's configuration (a driven NMF character).

What `pre` works out from the wired signals (`driven`) is worked out again only when a signal's value
changed (`changed_inputs`): a signal is mostly steady between commands, and resolving the block's
drivable parameters costs more than the kernel's own step for most ops.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

import numpy as np

from backend.engine.blocks.base import Block
from backend.engine.blocks.core import GainOffset, Output, RestPose, SafetyLimiter
from backend.engine.blocks.mixer import LayerMixer
from backend.engine.blocks.motion_filter import MotionFilterBlock, MotionFilterStage2
from backend.engine.core import vm
from backend.engine.frames import FrameEvent, PartialFrame
from backend.engine.nmf import MotionFilter

if TYPE_CHECKING:
    from backend.engine.core.program import Arena, Refs

NO_EVENTS: list[FrameEvent] = []

_ATOMS = (str, bool, int, type(None))
# The same object of one of these types is the same value to `same_value` (a list it compares with
# itself, element by element, so one changed in place would go unseen either way); arrays never are.
_SAME_WHEN_IDENTICAL = (float, *_ATOMS, list, tuple)


def same_value(new: Any, old: Any) -> bool:
    """Whether a signal's value `new` is the value `old` for every use a block makes of it: the same
    type and value, with a zero's sign (atan2 tells -0.0 from 0.0); a NaN only as the same object;
    lists and tuples element by element. Arrays and other values are never the same (a block may
    have written into the one it sent before)."""
    kind = type(new)
    if kind is not type(old):
        return False
    if kind is float:
        return new == old and (new != 0.0 or math.copysign(1.0, new) == math.copysign(1.0, old))
    if kind in _ATOMS:
        return bool(new == old)
    if kind is list or kind is tuple:
        try:  # equal and of the same types, in C loops; with a zero (its sign) element by element
            if new != old or [*map(type, new)] != [*map(type, old)]:
                return False
            return 0 not in new or all(map(same_value, new, old))
        except (ValueError, TypeError):  # an array inside: never the same
            return False
    return False


B = TypeVar("B", bound=Block)


class Op(Generic[B]):
    """One compiled step. `frame` is what Python readers of its output see (values: its arena row)."""

    code: ClassVar[int] = vm.NOP
    n_scalars: ClassVar[int] = 0
    needs_kernel: ClassVar[bool] = True  # compiled only when the block runs its own compiled tick
    # When `pre` runs: "always" (every tick), "wired" (a signal input is: when one changed value), "inputs"
    # (as "wired", and once after each bind even with none wired), "never".
    pre_when: ClassVar[str] = "wired"
    passes_events: ClassVar[bool] = True  # whether `post` runs (sources have no events to pass)
    # Whether `changed` runs when any block changed (parameters, state or a command: blocks/block_state.py).
    watches_changes: ClassVar[bool] = False
    post_always: ClassVar[bool] = False  # whether `post` has work beside events (else it runs only when
    # a frame into the segment carries events, or did on the tick before: the ones it passed are cleared)
    frame_inputs: ClassVar[tuple[str, ...]] = ("in",)  # the frame ports, in the order rows are listed
    # The float parameters a compiled signal may drive in the kernel: port -> its scalar slot (after `s`).
    # The kernel works out whatever the op derives from them; other drivable ports are driven by `pre`.
    kernel_drives: ClassVar[dict[str, int]] = {}

    def __init__(self, k: int, step: int, block: B, arena: Arena, out: int, srcs: list[Any]):
        self.k, self.step, self.block, self.arena, self.out = k, step, block, arena, out
        self.row = out
        self.refs: Refs | None = None
        self.srcs = srcs  # per frame input: the object whose `.frame` is that input's frame (or None)
        self.s = arena.scalar_slots(self.n_scalars)
        self.signal_ports: tuple[tuple[str, int, str], ...] = ()  # (port, source step, source port)
        self.input_wires: tuple[tuple[str, int, str], ...] = ()  # every signal wired in, as above
        self.outputs_read = False  # whether a step reads one of its signal outputs in Python (a `pre` too)
        self.seg: Any = None  # its Segment (program.py), told when the op is bound again
        # (port, source's output slot) per parameter a compiled signal drives in the kernel
        self.drive_wires: tuple[tuple[str, int], ...] = ()
        self.frame = PartialFrame(arena.V[out], arena.P[out].copy(), NO_EVENTS)
        self.result: dict[str, Any] = {"out": self.frame}
        self._params: Any = None
        self._state: Any = None
        self._signals: list[Any] | None = None  # the wired signals' values `pre` last worked from
        self.every_tick = False  # whether `pre` runs every tick (else: when `due` or `_signals` is None)
        self.due = -1  # the core tick in which a Python source of its signals last ticked

    # --- binding ------------------------------------------------------------------------------------
    def stale(self) -> bool:
        b = self.block
        return b.params is not self._params or getattr(b, "state", None) is not self._state

    def bind(self, refs: Refs) -> None:
        """List the block's arrays (again) and write its constant scalars."""
        b = self.block
        self.refs = refs
        self._params, self._state = b.params, getattr(b, "state", None)
        self._signals = None
        if self.seg is not None:
            self.seg.unbound = True  # its `pre` must run before the next kernel run
        row = self.arena.ops[self.k]
        row[:] = -1
        row[0], row[1], row[3] = self.code, self.out, self.s
        src = self.srcs[0] if self.srcs and self.frame_inputs == ("in",) else None
        row[2] = -1 if src is None else src.row
        for col, array in enumerate(self.arrays(), start=4):
            row[col] = refs.put(self.k, col, array)
        if self.drive_wires:  # (the table keeps the array alive)
            row[vm.DRIVES] = refs.put(self.k, vm.DRIVES, self.drive_table())
        self.bound_extra()

    def drive_table(self) -> np.ndarray:
        """The kernel's drives into this op (compiled/signals.py's `drive`): per wire its source slot, its
        parameter's slot, the parameter's clamp bounds and the parameter itself (for a value not finite)."""
        b = self.block
        rows = []
        for port, src_slot in self.drive_wires:
            d = b.drivables[port]
            lo = -math.inf if d.lo is None else float(d.lo)
            hi = math.inf if d.hi is None else float(d.hi)
            rows.append(
                (
                    src_slot,
                    self.s + self.kernel_drives[port],
                    lo,
                    hi,
                    d.resolve(None, getattr(b.params, port)),
                )
            )
        return np.array(rows, dtype=float)

    def bound_extra(self) -> None:
        """What an op remembers of its block beyond params and state, to know when it is stale."""

    def rebind_if_stale(self) -> None:
        if self.refs is not None and self.stale():
            self.bind(self.refs)

    def arrays(self) -> list[np.ndarray]:
        """The arrays the kernel reads, in the op's column order (see vm.py)."""
        return []

    # --- ticking ------------------------------------------------------------------------------------
    def changed_inputs(self, results: list[dict[str, Any]]) -> dict[str, Any] | None:
        """The block's wired signal inputs, or None when each has the value it had at the last call since
        the op was bound (or `forget_inputs`): what `pre` wrote from them still holds."""
        ports, last = self.signal_ports, self._signals
        if last is not None:
            for (_, src, src_port), old in zip(ports, last):
                new = results[src].get(src_port)
                if (new is not old or type(new) not in _SAME_WHEN_IDENTICAL) and not same_value(new, old):
                    break
            else:
                return None
        self._signals = values = [results[src].get(src_port) for _, src, src_port in ports]
        return {port: value for (port, _, _), value in zip(ports, values)}

    def restore(self, results: list[dict[str, Any]]) -> None:
        """The APU ran the blocks' own ticks since the last core tick: put the op's result back in `results`
        and make its state ready for the kernel."""
        results[self.step] = self.result
        self.forget_inputs()
        self.resume()

    def publish(self, results: list[dict[str, Any]]) -> None:
        """The kernel flagged the op's output changed (`CH`): show Python readers the new one."""
        self.frame.mask = self.arena.P[self.out].copy()  # a new object: a held mask never changes

    def forget_inputs(self) -> None:
        """Work from the signals again at the next `pre` (the block's own tick may have run in between)."""
        self._signals = None

    def new_dt(self, dt: float) -> None:
        """The tick's dt changed (a new rate): what the op worked out from the last one."""

    def service(self) -> None:
        """Python's part after a kernel run that asked for it (the ops it flagged in `SV`: a noise's next
        draws, a blink's start)."""

    def trap(self, dt: float, results: list[dict[str, Any]]) -> bool | None:
        """Python's part of this tick's step, before the kernel runs the op (it stopped there: `vm.TRAP`);
        `results` holds every output so far this tick. True when the op's frame now carries events."""
        raise RuntimeError(f"compiled core: {type(self).__name__} has no Python part to trap to")

    def resume(self) -> None:
        """The APU ran the blocks' own ticks since the last core tick: make the state ready for the kernel."""

    def refresh(self, results: list[dict[str, Any]]) -> None:
        """Bring the outputs Python readers see (and the block's state) up to date before something reads
        them that the kernel does not know of: a probe, a trap, the blocks' own ticks, a swap's adoption
        (ops whose outputs are worked out lazily only: a clip player's, a signal no Python step reads)."""

    def needs_pre(self) -> bool:
        return self.pre_when in ("always", "inputs") or (self.pre_when == "wired" and bool(self.signal_ports))

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        """Python's part before the kernel runs (scalars, random draws)."""

    def changed(self) -> None:
        """Python's part at edit or command time (`watches_changes` ops only): what a command set, e.g. an
        LED's colour, into the scalars the kernel reads."""

    def post(self) -> None:
        """Python's part after: the events the frame out carries."""
        src = self.srcs[0].frame if self.srcs else None
        self.frame.events = src.events if src is not None else NO_EVENTS


class SourceOp(Op[B]):
    """An op of a source: no frame in, no events to pass; Python's part (a phase, random draws) runs
    every tick."""

    frame_inputs = ()
    pre_when = "always"
    passes_events = False


class RestOp(SourceOp[RestPose]):
    needs_kernel = False
    pre_when = "never"

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        b, a = self.block, self.arena
        a.V[self.out] = b.emb.rest
        a.M[self.out] = b.mask
        a.A[self.out] = True


class GainOffsetOp(Op[GainOffset]):
    code = vm.GAIN_OFFSET
    n_scalars = 2
    kernel_drives = {"gain": 0, "offset": 1}

    def arrays(self) -> list[np.ndarray]:
        return [self.block.sel]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        self._scalars(self.block.driven({}))

    def _scalars(self, d: Any) -> None:
        self.arena.S[self.s] = float(d.gain)
        self.arena.S[self.s + 1] = float(d.offset)

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)
        if inputs is not None:
            self._scalars(self.block.driven(inputs))


class FilterOp(Op[MotionFilterBlock | MotionFilterStage2]):
    code = vm.FILTER
    n_scalars = 1

    def _motion_filter(self) -> MotionFilter:
        f = self.block.filter
        if f is None:  # op_class compiles no filter block without channels (it has no filter)
            raise RuntimeError(f"filter block '{self.block.node_id}' has no filter")
        return f

    def arrays(self) -> list[np.ndarray]:
        b = self.block
        buf, cfg, _ = self._motion_filter().kernel_buffers()
        return [b._idx64, b._sp, cfg, buf, b._no_mask]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        self.arena.S[self.s] = 1.0 if self._motion_filter().kernel_buffers()[2] else 0.0

    def stale(self) -> bool:
        f = self.block.filter
        if super().stale() or f is not self._filter or f is None:
            return True
        buf, cfg, _ = f.kernel_buffers()
        return buf is not self._buf or cfg is not self._cfg

    def bound_extra(self) -> None:
        self._filter = f = self._motion_filter()
        self._buf, self._cfg, _ = f.kernel_buffers()

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)  # (`pre` runs only with a signal wired)
        if inputs is not None:  # a driven character: what the block's tick does before its kernel
            b = self.block
            wired = b.driven(inputs, sigma=None, rho=None)
            if wired.sigma is not None or wired.rho is not None:
                s, r, _ = b._character(wired.sigma, wired.rho)
                if (s, r) != b._sigma_rho:
                    self._motion_filter().set_params(sigma=s, rho=r)
                    b._sigma_rho = (s, r)
                    self.rebind_if_stale()  # set_params may have replaced the filter's buffers


class LimiterOp(Op[SafetyLimiter]):
    code = vm.LIMITER

    def arrays(self) -> list[np.ndarray]:
        b = self.block
        return [b.state.last, b.lo, b.hi, b.vmax, b.emb.continuous_mask]


class OutputOp(Op[Output]):
    code = vm.HOLD

    def __init__(self, k: int, step: int, block: Output, arena: Arena, out: int, srcs: list[Any]):
        super().__init__(k, step, block, arena, out, srcs)
        self.result = {"frame": self.frame}

    def arrays(self) -> list[np.ndarray]:
        return [self.block.state.held]

    def publish(self, results: list[dict[str, Any]]) -> None:
        """(The output's frame is its held state, whose mask never changes: nothing to show.)"""

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        self.frame.values, self.frame.mask = self.block.state.held, self.block._every


class MixerOp(Op[LayerMixer]):
    code = vm.MIXER

    def __init__(self, k: int, step: int, block: LayerMixer, arena: Arena, out: int, srcs: list[Any]):
        super().__init__(k, step, block, arena, out, srcs)
        n = block.emb.n_channels * len(srcs)
        self._gathered = (np.zeros(n), np.zeros(n, dtype=bool))
        self._rows = np.array([-1 if src is None else src.row for src in srcs], dtype=np.int64)

    def arrays(self) -> list[np.ndarray]:
        b, st = self.block, self.block.state
        return [
            self._rows,
            b.weights,
            st.fade_level,
            st.fade_target,
            b.fade_time,
            b.signal_weights,
            b._w,
            *self._gathered,
            b.layer_masks,
            b._mode_codes,
        ]

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)
        if inputs is not None:
            self.block._read_weight_ports(inputs)

    def post(self) -> None:
        w = self.block._w
        events = NO_EVENTS
        for i, src in enumerate(self.srcs):
            frame = None if src is None else src.frame
            if frame is not None and frame.events and w[i] > 0.0:
                events = [*events, *frame.events]
        self.frame.events = events
