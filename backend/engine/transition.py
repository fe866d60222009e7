"""Swap transitions: the jump between the last output and a new program's is blended out.

When a program is swapped in (a structural edit, New/Open in the editor, `reset`, shutdown), its
first frame can be far from the pose the robot shows, and its motion different from the robot's.
The transition measures the offset on the new program's first tick (position: where the robot
would be one tick on, minus the program's first sample) and second tick (velocity: the robot's
velocity at the swap minus the program's), and decays both to zero with a quintic that ends flat
(zero velocity and acceleration) while the new program runs underneath, so its own motion is not
paused (the game-animation technique known as *inertialization*). The duration is the shortest in
which the decay alone stays within every continuous DoF's velocity, acceleration and jerk limits,
and at least the requested one; the safety net downstream bounds the sum.
"""

from __future__ import annotations

import numpy as np

from backend.engine.embodiment import Embodiment

# The offset decays as x0 P(u) + v0 T Q(u), u = t/T in [0, 1], with P(0) = 1, Q'(0) = 1 and every
# other value and derivative up to the second 0 at both ends:
#   P = 1 - 10u^3 + 15u^4 - 6u^5,   Q = u - 6u^3 + 8u^4 - 3u^5.
# Peak magnitudes on [0, 1] of P', P'', P''' and of Q'', Q''':
_P_PEAKS = (15.0 / 8.0, 10.0 / np.sqrt(3.0), 60.0)
_Q_PEAKS = (3.95, 36.0)
#: The shortest transition (s); a swap with no offset ends at once.
MIN_SECONDS = 0.2
#: A transition never lasts longer than this (s), however large the offset.
MAX_SECONDS = 5.0


def seconds_needed(emb: Embodiment, x0: np.ndarray, v0: np.ndarray | None = None) -> float:
    """The shortest decay of a position offset `x0` and velocity offset `v0` (C,) within every
    continuous DoF's V, A and J (s): each term gets half of each limit."""
    cont = emb.continuous_mask
    d = 2.0 * np.abs(np.where(cont, x0, 0.0))
    w = 2.0 * np.abs(np.where(cont, v0, 0.0)) if v0 is not None else np.zeros_like(d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.maximum.reduce(
            [
                _P_PEAKS[0] * d / emb.vel_limit,
                np.sqrt(_P_PEAKS[1] * d / emb.acc_limit),
                np.cbrt(_P_PEAKS[2] * d / emb.jerk_limit),
                _Q_PEAKS[0] * w / emb.acc_limit,
                np.sqrt(_Q_PEAKS[1] * w / emb.jerk_limit),
            ]
        )
    t = np.where(np.isfinite(t), t, 0.0)
    return float(t.max(initial=0.0))


class Transition:
    """One swap's blend. `apply(target)` adds the decaying offset in place; True when it is over."""

    def __init__(
        self, emb: Embodiment, last: np.ndarray, velocity: np.ndarray, rate: float, seconds: float | None
    ):
        self.emb = emb
        self.dt = 1.0 / rate
        cont = emb.continuous_mask
        self.velocity = np.where(cont, np.asarray(velocity, dtype=float), 0.0)
        # Where the robot would be one tick on, had nothing changed.
        self.ahead = np.where(cont, np.asarray(last, dtype=float) + self.dt * self.velocity, 0.0)
        self.requested = seconds
        self.x0: np.ndarray | None = None
        self.v0: np.ndarray | None = None
        self.first: np.ndarray | None = None
        self.seconds = 0.0
        self.t = 0.0

    @classmethod
    def start(
        cls, emb: Embodiment, last: np.ndarray, velocity: np.ndarray, rate: float, seconds: float | None
    ) -> Transition | None:
        """A transition from the pose `last` moving at `velocity`; None when `seconds` is 0 (the
        safety net alone then bounds the jump)."""
        if seconds is not None and seconds <= 0.0:
            return None
        return cls(emb, last, velocity, rate, seconds)

    def apply(self, target: np.ndarray) -> bool:
        cont = self.emb.continuous_mask
        if self.x0 is None:  # the new program's first tick: the position offset
            x0 = np.where(cont, self.ahead - target, 0.0)
            self.x0 = np.where(np.isfinite(x0), x0, 0.0)
            self.first = target.copy()
            target += self.x0
            return False
        if self.v0 is None:  # its second: the velocity offset, and so the duration
            v0 = np.where(cont, self.velocity - (target - self.first) / self.dt, 0.0)
            self.v0 = np.where(np.isfinite(v0), v0, 0.0)
            need = seconds_needed(self.emb, self.x0, self.v0)
            wanted = MIN_SECONDS if self.requested is None else self.requested
            self.seconds = min(MAX_SECONDS, max(need, wanted)) if (self.x0.any() or self.v0.any()) else 0.0
        if self.seconds <= 0.0:
            return True
        self.t += self.dt
        u = min(self.t / self.seconds, 1.0)
        p = 1.0 - u * u * u * (10.0 + u * (-15.0 + 6.0 * u))
        q = u * (1.0 + u * u * (-6.0 + u * (8.0 - 3.0 * u)))
        target += self.x0 * p + self.v0 * (self.seconds * q)
        return u >= 1.0
