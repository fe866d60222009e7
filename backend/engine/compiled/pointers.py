"""Arrays read by address in compiled code: a table row (address, shape0, shape1, shape2) as an array.

Each array a compiled function receives as an argument costs its unboxing (and a small allocation)
per call, so the kernels that read many arrays (the program core, the engine's frame tail) take one
int64 table of their addresses instead. Whoever fills a table keeps every array it lists alive, checks
that it is C-contiguous with the dtype the kernel reads, and lists it again when it is replaced: an
address always points into a live array of the recorded shape.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit
from numba import types as nt
from numba.extending import intrinsic
from numba.np.numpy_support import carray


def _pointer_typing(typingctx, address):
    """The int64 `address` as a void pointer (for `carray`)."""
    sig = nt.voidptr(nt.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(nt.voidptr))

    return sig, codegen


# Called with the address alone in compiled code (numba supplies the typing context).
_pointer: Any = intrinsic(_pointer_typing)


@njit(cache=True, inline="always")
def f1(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1],), np.float64)


@njit(cache=True, inline="always")
def b1(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1],), np.bool_)


@njit(cache=True, inline="always")
def i1(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1],), np.int64)


@njit(cache=True, inline="always")
def f2(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1], refs[j, 2]), np.float64)


@njit(cache=True, inline="always")
def f3(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1], refs[j, 2], refs[j, 3]), np.float64)


@njit(cache=True, inline="always")
def i2(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1], refs[j, 2]), np.int64)


@njit(cache=True, inline="always")
def b2(refs, j):
    return carray(_pointer(refs[j, 0]), (refs[j, 1], refs[j, 2]), np.bool_)


class AddressTable:
    """The table of arrays a kernel reads by address, and the arrays themselves, kept alive."""

    def __init__(self, rows: int):
        self.table = np.zeros((rows, 4), dtype=np.int64)
        self._held: dict[int, np.ndarray] = {}

    def put_at(self, j: int, array: np.ndarray) -> int:
        """List `array` at row `j` of the table; `j`."""
        if not (isinstance(array, np.ndarray) and array.flags.c_contiguous and 1 <= array.ndim <= 3):
            raise TypeError(f"refs row {j}: not a C-contiguous 1-D to 3-D array")
        self._held[j] = array  # before its address is written: the table never names a freed array
        shape = array.shape + (0,) * (3 - array.ndim)
        self.table[j] = (array.ctypes.data, *shape)
        return j

    def held(self, j: int) -> np.ndarray | None:
        """The array listed at row `j` (None: none)."""
        return self._held.get(j)
