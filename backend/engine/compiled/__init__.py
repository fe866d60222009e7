"""Compiled (numba) kernels of the blocks users run most — IK, gaze, the layer mixer, breathing, noise —
and the switch back to their numpy references.

Each kernel does the whole tick of one block in one call. Its numpy reference is the block's own code
(the readable definition); `tests/test_compiled_blocks.py` checks that both agree, block by block and
over whole programs.

- `BlockContext.compiled` (default `default_compiled()`) picks the path for the blocks of an engine:
  `Engine(..., compiled=False)` or the environment variable `NUTTY_REFERENCE=1` run the references
  (tests and benchmarks compare the two).
- `entry_point(dispatcher, signature)` compiles a kernel for one signature (from numba's on-disk cache
  when it is there) and returns the machine-code entry, which skips the dispatcher's type resolution
  (most of the cost of a short call). Blocks fetch their entries in `configure()`, so no kernel is
  ever compiled on the clock thread.
- An entry point checks argument types but not shapes or strides: a 2-D or strided array would be
  read as the 1-D contiguous one it expects. Callers pass arrays they made themselves, or check
  frames from other blocks with `plain_frame` first (anything else takes the numpy reference).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numba import types as nt

#: Environment variable that selects the numpy references everywhere ("1": reference, else compiled).
REFERENCE_ENV = "NUTTY_REFERENCE"

f8 = nt.float64
i8 = nt.int64
b1 = nt.boolean
f8_1 = nt.float64[::1]
f8_2 = nt.float64[:, ::1]
f8_3 = nt.float64[:, :, ::1]
i8_1 = nt.int64[::1]
i8_2 = nt.int64[:, ::1]
b1_1 = nt.boolean[::1]
b1_2 = nt.boolean[:, ::1]


def default_compiled() -> bool:
    """Whether blocks use their compiled kernels unless told otherwise (`NUTTY_REFERENCE=1`: no)."""
    return os.environ.get(REFERENCE_ENV, "").strip() not in ("1", "true", "yes")


_F64, _BOOL, _NDARRAY = np.dtype(np.float64), np.dtype(np.bool_), np.ndarray


def plain_frame(frame: Any, n: int) -> bool:
    """Whether a PartialFrame's arrays are what the kernels take: float64 values and a bool mask, both
    1-D, contiguous, of length `n` (the embodiment's channels)."""
    v, m = frame.values, frame.mask
    # (ndim and size as ints: cheaper than comparing shape tuples, and the same test)
    return (
        type(v) is _NDARRAY
        and type(m) is _NDARRAY
        and v.dtype is _F64
        and m.dtype is _BOOL
        and v.ndim == 1
        and m.ndim == 1
        and v.size == n
        and m.size == n
        and v.flags.c_contiguous
        and m.flags.c_contiguous
    )


_ENTRIES: dict[tuple[int, tuple], Any] = {}


def entry_point(dispatcher: Any, signature: tuple) -> Any:
    """The compiled entry of `dispatcher` for `signature` (a tuple of numba types), compiled once."""
    key = (id(dispatcher), signature)
    entry = _ENTRIES.get(key)
    if entry is None:
        dispatcher.compile(signature)
        entry = _ENTRIES[key] = dispatcher.overloads[signature].entry_point
    return entry
