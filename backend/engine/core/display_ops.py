"""Ops of the display sources (backend/engine/blocks/display.py): what the kernel computes of an LED.

The LED's brightness curve and the clipped colour run in the kernel; Python's part every tick is the
phase, a float of the block's state that its own tick steps too (`Led.advance`, shared by both). The
colour and depth are worked out again only when a wired signal or the `set_led` command changes them,
as the block's tick would.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from backend.engine.blocks.display import Led
from backend.engine.core import vm
from backend.engine.core.ops import SourceOp

if TYPE_CHECKING:
    from backend.engine.core.program import Refs

#: Led.params.mode as the kernel's code (vm.LED's scalar `mode`).
LED_MODES = {"solid": vm.LED_SOLID, "breathe": vm.LED_BREATHE, "pulse": vm.LED_PULSE}

_UNSEEN = object()  # no colour worked out yet since the op was bound


class LedOp(SourceOp[Led]):
    """S: r, g, b, mode, depth, phase (cycles, 0..1), first channel, components | 4 mask."""

    code = vm.LED
    n_scalars = 8
    needs_kernel = False  # the block has no compiled tick: the op's arithmetic is Led.tick's

    def arrays(self) -> list[np.ndarray]:
        return [self.block.mask]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        b, S, s = self.block, self.arena.S, self.s
        S[s + 3] = LED_MODES[b.params.mode]
        S[s + 6] = float(b.dof.channels.start)
        self._fallback: Any = _UNSEEN
        self._inputs: dict[str, Any] = {}
        self._frequency = 0.0

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        b = self.block
        fallback = b.fallback_colour()
        changed = self.changed_inputs(results) if self.signal_ports else None
        if changed is not None:
            self._inputs = changed
        if changed is not None or fallback is not self._fallback:
            self._colour(fallback)
        self.arena.S[self.s + 5] = b.advance(self._frequency, dt)

    def _colour(self, fallback: Any) -> None:
        """Colour, depth and frequency from the wired signals and the fallback, as Led.tick resolves them."""
        S, s = self.arena.S, self.s
        d, rgb = self.block.resolve(self._inputs, fallback)
        n = min(len(rgb), 3)
        S[s : s + n] = rgb[:n]
        S[s + 7] = float(n)
        S[s + 4] = float(d.depth)
        self._frequency = float(d.frequency)
        self._fallback = fallback
