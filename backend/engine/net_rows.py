"""The rows of the safety net's arrays, by name: its state, and the limits it enforces.

Each array has one column per governed channel (or joint, in the joint stage); the net's kernel
(`backend.engine.safety._net_step`) and every reader address a row only by these names, so the order
below is defined in one place.
"""

from __future__ import annotations

import numpy as np

#: Rows of the net's state: the output's finite-difference state (position, velocity, acceleration),
#: then the program's (clipped to the limits, for prediction).
ROW_P, ROW_V, ROW_A, ROW_TX, ROW_TV, ROW_TA = range(6)
STATE_ROWS = 6
#: Rows of the limits array: position range (lo, hi), velocity, acceleration and jerk limits.
LIM_LO, LIM_HI, LIM_V, LIM_A, LIM_J = range(5)
LIMIT_ROWS = 5


def limit_rows(lo: np.ndarray, hi: np.ndarray, V: np.ndarray, A: np.ndarray, J: np.ndarray) -> np.ndarray:
    """The limits array (LIMIT_ROWS, n) of n governed channels or joints, each row at its name: position
    range (rad or m), velocity (/s), acceleration (/s²) and jerk (/s³) limits; contiguous float64."""
    rows = np.empty((LIMIT_ROWS, len(lo)))
    rows[LIM_LO], rows[LIM_HI], rows[LIM_V], rows[LIM_A], rows[LIM_J] = lo, hi, V, A, J
    return rows


def rest_state(position: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """A net's state (STATE_ROWS, n) standing still at `position` clipped to [lo, hi]: the output and
    the program both there, with zero velocity and acceleration."""
    state = np.zeros((STATE_ROWS, len(position)))
    state[ROW_P] = np.clip(position, lo, hi)
    state[ROW_TX] = state[ROW_P]
    return state
