"""The paper's example inputs for the NMF (60 Hz, 10 s): Φ_L, Φ_R and Φ_C."""

from __future__ import annotations

import numpy as np

RATE = 60.0
DURATION = 10.0


def times(rate: float = RATE, duration: float = DURATION) -> np.ndarray:
    return np.arange(round(rate * duration)) / rate


def phi_l(rate: float = RATE) -> np.ndarray:
    """Set-point 5, jumps to -5 at t = 2.5 s and back to 5 at t = 7.5 s."""
    t = times(rate)
    return np.where((t >= 2.5) & (t < 7.5), -5.0, 5.0)


def phi_r(rate: float = RATE, seed: int = 7) -> np.ndarray:
    """A new random set-point (uniform in [-10, 10]) every second; fixed seed for reproducibility."""
    t = times(rate)
    values = np.random.default_rng(seed).uniform(-10.0, 10.0, size=int(DURATION) + 1)
    values[0] = 2.5
    return values[np.floor(t).astype(int)]


def phi_c(rate: float = RATE) -> np.ndarray:
    """One axis of a circle of radius 5 sampled at 50 points: a stepped cosine, one step per 0.2 s."""
    t = times(rate)
    k = np.floor(t / 0.2)
    return 5.0 * np.cos(2 * np.pi * k / 50.0)


EXAMPLES = {"Φ_L": phi_l, "Φ_R": phi_r, "Φ_C": phi_c}
