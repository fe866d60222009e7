"""Ops of the display sources (backend/engine/blocks/display.py): what the kernel computes of an LED.

The LED's brightness curve, the clipped colour and the phase (the block's `state.phase`, which its own
tick steps too) run in the kernel. Python's part every tick is a look at the colour a command set: the
colour, depth and frequency are worked out again only when a wired signal or the `set_led` command
changes them, as the block's tick would.
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
    """S: r, g, b, mode, depth, phase (cycles, 0..1: written by the kernel), first channel, components,
    frequency (Hz) | 4 mask, 5 the state's phase (1,)."""

    code = vm.LED
    n_scalars = 9
    needs_kernel = False  # the block has no compiled tick: the op's arithmetic is Led.tick's

    def arrays(self) -> list[np.ndarray]:
        return [self.block.mask, self.block.state.phase]

    def bind(self, refs: Refs) -> None:
        super().bind(refs)
        b, S, s = self.block, self.arena.S, self.s
        S[s + 3] = LED_MODES[b.params.mode]
        S[s + 6] = float(b.dof.channels.start)
        self._fallback: Any = _UNSEEN
        self._inputs: dict[str, Any] = {}

    def pre(self, dt: float, results: list[dict[str, Any]]) -> None:
        b = self.block
        commanded = b.state.commanded  # Led.fallback_colour, inline: it is asked every tick
        fallback = commanded if commanded is not None else b.params.colour
        changed = self.changed_inputs(results) if self.signal_ports else None
        if changed is not None:
            self._inputs = changed
        if changed is not None or fallback is not self._fallback:
            self._colour(fallback)

    def _colour(self, fallback: Any) -> None:
        """Colour, depth and frequency from the wired signals and the fallback, as Led.tick resolves them."""
        S, s = self.arena.S, self.s
        d, rgb = self.block.resolve(self._inputs, fallback)
        n = min(len(rgb), 3)
        S[s : s + n] = rgb[:n]
        S[s + 7] = float(n)
        S[s + 4] = float(d.depth)
        S[s + 8] = float(d.frequency)
        self._fallback = fallback
