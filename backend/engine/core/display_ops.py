"""Ops of the display sources (backend/engine/blocks/display.py): what the kernel computes of an LED.

The LED's brightness curve, the clipped colour and the phase (the block's `state.phase`, which its own
tick steps too) run in the kernel. The colour, depth and frequency are worked out again in Python only
when a wired signal changed them (`pre`) or a command may have (`changed`: a `set_led` colour), as the
block's tick would: a steady LED runs no Python.
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
    pre_when = "inputs"  # the wired signals when one changed, and once after each bind
    watches_changes = True  # the colour a set_led command sets

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
        inputs = self.changed_inputs(results)  # (after a bind, or when a wired signal's source ticked)
        if inputs is not None:
            self._inputs = inputs
            self._colour(self._fallback_colour())

    def changed(self) -> None:
        fallback = self._fallback_colour()
        if fallback is not self._fallback:  # a set_led command (or an edit) changed it
            self._colour(fallback)

    def _fallback_colour(self) -> Any:
        commanded = self.block.state.commanded  # (Led.fallback_colour, inline)
        return commanded if commanded is not None else self.block.params.colour

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
