"""The ops of the blocks that solve on a kinematic chain: the gaze (a source) and the IK (an operator).

Their kernels take the chain's arrays (`backend.engine.compiled.kinematics.chain_args`) and the block's
solver constants from `_kernel_args`, which `configure` builds; the ops list them as they are.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.blocks.gaze import Gaze
from backend.engine.blocks.ik import InverseKinematics
from backend.engine.core import vm
from backend.engine.core.ops import NO_EVENTS, Op, SourceOp

if TYPE_CHECKING:
    from backend.engine.core.program import Arena, Refs


class GazeOp(SourceOp[Gaze]):
    code = vm.GAZE
    n_scalars = 13
    pre_when = "inputs"  # the target and strength; the kernel steps the arc dip (the state's `dip_cell`)
    # The kernel also counts a look_at's still ticks (the state's `still_cell`) and asks for `service` when
    # the look_at ends or `on_target` changes; whether a look_at is in progress is a command's (`changed`).
    watches_changes = True

    def __init__(self, k: int, step: int, block: Gaze, arena: Arena, out: int, srcs: list[Any]):
        super().__init__(k, step, block, arena, out, srcs)
        self._x_old = np.zeros(len(block.state.x))
        self.result["on_target"] = False

    def arrays(self) -> list[np.ndarray]:
        b = self.block
        args: tuple[Any, ...] = (
            b._kernel_args
        )  # (idx, axis, leader, constants, 4 floats, j_rows, chain, identity, workspace)
        if self._x_old.shape != b.state.x.shape:
            self._x_old = np.zeros(b.state.x.shape)
        return [
            b.state.x,
            self._x_old,
            b.state.dip_cell,
            args[0],
            args[1],
            args[2],
            args[3],
            args[8],
            *args[9:19],
            b.mask,
            args[20],
            b.state.still_cell,
        ]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        args, S, s = self.block._kernel_args, self.arena.S, self.s
        for i in range(4):  # arc_dip, arc_max, arc smoothing, tolerance
            S[s + 5 + i] = float(args[4 + i])
        S[s + 9] = 1.0 if args[19] else 0.0
        self.resume()

    def stale(self) -> bool:
        b = self.block  # the block's own tick replaces x each tick
        return super().stale() or b.state.x is not self._x

    def bound_extra(self) -> None:
        self._x = self.block.state.x

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        b = self.block
        inputs = self.changed_inputs(results)
        if inputs is not None:
            d, S, s = b.driven(inputs), self.arena.S, self.s
            target = d.target
            S[s] = float(d.strength)
            S[s + 1], S[s + 2], S[s + 3] = target[0], target[1], target[2]

    def resume(self) -> None:
        """Whether a look_at is in progress, and `on_target` as Python's readers last saw it."""
        S, s = self.arena.S, self.s
        S[s + 11] = 0.0 if getattr(self.block, "_watch", None) is None else 1.0
        S[s + 12] = 1.0 if self.result["on_target"] else 0.0

    changed = resume  # a look_at command began, was replaced or cancelled

    def service(self) -> None:
        S, s = self.arena.S, self.s
        on = bool(S[s + 10] > 0.5)
        self.result["on_target"] = on
        if S[s + 11] < 0.5 and getattr(self.block, "_watch", None) is not None:  # the kernel ended it
            self.block.watch_completed(on)


class IkOp(Op[InverseKinematics]):
    code = vm.IK
    n_scalars = 15
    pre_when = "inputs"  # the target and weight decide whether it solves (worked out when they change)

    def arrays(self) -> list[np.ndarray]:
        b, st = self.block, self.block.state
        args: tuple[Any, ...] = (
            b._kernel_args
        )  # (j_rows, var, var_ch, constants, look, ..., chain, identity, ws)
        return [st.held, st.delta, b.mask_add, args[0], args[1], args[2], args[3], *args[11:21], args[22]]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        args, S, s = self.block._kernel_args, self.arena.S, self.s
        S[s + 4] = 1.0 if args[4] else 0.0
        for i in range(6):  # lam2, iterations, max_step, converged, null_gain, null_range
            S[s + 5 + i] = float(args[5 + i])
        S[s + 11] = 0.0
        S[s + 12] = 1.0 if args[21] else 0.0

    def stale(self) -> bool:
        st = self.block.state  # the block's own tick replaces these when it does not solve
        return super().stale() or st.held is not self._held or st.delta is not self._delta

    def bound_extra(self) -> None:
        self._held, self._delta = self.block.state.held, self.block.state.delta

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        inputs = self.changed_inputs(results)
        if inputs is None:
            return
        b = self.block
        d, S, s = b.driven(inputs), self.arena.S, self.s
        target, weight = d.target, d.weight
        solve = target is not None and weight > 0.0 and len(b.var) > 0
        S[s] = float(weight)
        if solve and target is not None:
            S[s + 1], S[s + 2], S[s + 3] = target[0], target[1], target[2]
        S[s + 13] = 1.0 if solve else 0.0
        S[s + 14] = 1.0 if target is None else 0.0

    def post(self) -> None:
        src = self.srcs[0].frame if self.srcs else None
        self.frame.events = src.events if src is not None else NO_EVENTS
