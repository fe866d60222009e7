"""Branch-free `tanh` and power for the NMF's compiled kernels, and the numba import they share.

libm's tanh and pow cannot be vectorised, so a loop calling them runs one DoF at a time; these are
built from adds, multiplies and bit casts only, so the kernels' loops over DoFs compile to SIMD code.
`_tanh` is within 4 ulp of libm's and `_pow` within 2e-13 relative (see tests). Their numpy twins,
`tanh_np` and `pow_np` in `reference.py`, perform the same operations with the same constants (the
constants are defined here and imported there). Without numba, `njit` is a no-op decorator.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, cast

import numpy as np

try:  # numba is a hard dependency in pyproject; the fallback keeps the filter usable without it
    from numba import njit
    from numba import types as _nt
    from numba.core.extending import intrinsic

    HAVE_NUMBA = True

    # Bit casts between float64 and int64 (free in machine code, and vectorisable): they build 2**k
    # from k's bits inside _tanh.
    @intrinsic
    def _f2i_intrinsic(typingctx, x):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(_nt.int64))

        return _nt.int64(_nt.float64), codegen

    @intrinsic
    def _i2f_intrinsic(typingctx, x):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], context.get_value_type(_nt.float64))

        return _nt.float64(_nt.int64), codegen

    # As jitted code calls them: one argument (numba supplies the typing context). numba's stubs type a
    # call with the definition's parameters and as never returning, which would hide the code after it.
    _f2i = cast(Callable[[float], int], _f2i_intrinsic)
    _i2f = cast(Callable[[int], float], _i2f_intrinsic)

except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False

    def njit(*_args: Any, **_kw: Any):
        return lambda fn: fn


# ------------------------------------------------------------------------------------------------
# tanh and pow for the compiled kernels (their numpy twins, tanh_np and pow_np, are in reference.py)
# ------------------------------------------------------------------------------------------------
# tanh(a) = expm1(2a) / (expm1(2a) + 2), with expm1 by Cody-Waite reduction 2a = k ln2 + r,
# |r| <= ln2/2, and a degree-13 Taylor polynomial for expm1(r) (truncation < 1e-17 relative).
# For |a| >= 20 the result rounds to exactly 1, so the argument is capped there (k <= 58).
_LN2_HI = 6.93147180369123816490e-01  # ln 2 with trailing zero bits: k * _LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00
_TANH_CAP = 20.0
_ROUND = 6755399441055744.0  # 1.5 * 2**52: adding it rounds to an integer held in the low bits
_ROUND_BITS = int(np.float64(_ROUND).view(np.int64))
_C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11, _C12, _C13 = (
    1.0 / math.factorial(k) for k in range(2, 14)
)


@njit(cache=True, error_model="numpy")
def _tanh(x):
    a = min(abs(x), _TANH_CAP)
    y = a + a
    kr = y * _INV_LN2 + _ROUND  # round to nearest without a call: vectorisable
    k = kr - _ROUND
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = r * (
        1.0
        + r
        * (
            _C2
            + r
            * (
                _C3
                + r
                * (
                    _C4
                    + r
                    * (
                        _C5
                        + r
                        * (
                            _C6
                            + r
                            * (_C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))
                        )
                    )
                )
            )
        )
    )
    s = _i2f(((_f2i(kr) - _ROUND_BITS) + 1023) << 52)  # 2**k (0 <= k <= 58) from k's bits, exact
    em1 = s * p + (s - 1.0)
    t = em1 / (em1 + 2.0)
    return t if x >= 0.0 else -t


# b**e for 0 <= b <= H_BASE_MAX and 0 < e < 1 (H's power), vectorisable: exp(e ln b) with ln b from
# b = m 2**E, m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh((m-1)/(m+1)) (series to f**23), and exp by the
# same reduction as in tanh. Relative error below 2e-13 (tested against libm's pow); H only uses the
# result inside tanh(p - pi), where that is far below the gain's own rounding.
_SQRT2 = 1.4142135623730951
_TWO600 = 2.0**600
_TINY = 2.0**-500  # smaller b are scaled up by 2**600 first (exact) to read their exponent
_L3, _L5, _L7, _L9, _L11, _L13, _L15, _L17, _L19, _L21, _L23 = (1.0 / k for k in range(3, 24, 2))
_EXP_LO, _EXP_HI = -700.0, 28.0  # e ln b lies in [-inf, ln 1e12 = 27.6]; below -700, b**e < 1e-304


@njit(cache=True, inline="always", error_model="numpy")
def _pow(b, e):
    small = b < _TINY
    bs = b * _TWO600 if small else b
    bits = _f2i(bs)
    ebits = (bits & 0x7FF0000000000000) >> 52  # masked first: a non-negative shift, which SIMD has
    m = _i2f((bits & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)  # mantissa in [1, 2)
    ex = (_i2f(ebits | _ROUND_BITS) - _ROUND) - 1023.0  # the exponent, as a float
    big = m > _SQRT2
    m = m * 0.5 if big else m
    ex = ex + (1.0 if big else 0.0) - (600.0 if small else 0.0)
    f = (m - 1.0) / (m + 1.0)
    f2 = f * f
    q = f2 * (
        _L3
        + f2
        * (
            _L5
            + f2
            * (
                _L7
                + f2
                * (
                    _L9
                    + f2
                    * (_L11 + f2 * (_L13 + f2 * (_L15 + f2 * (_L17 + f2 * (_L19 + f2 * (_L21 + f2 * _L23))))))
                )
            )
        )
    )
    lnb = ex * _LN2_HI + (ex * _LN2_LO + (f + f) * (1.0 + q))
    y = min(max(e * lnb, _EXP_LO), _EXP_HI)
    kr = y * _INV_LN2 + _ROUND
    k = kr - _ROUND
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = r * (
        1.0
        + r
        * (
            _C2
            + r
            * (
                _C3
                + r
                * (
                    _C4
                    + r
                    * (
                        _C5
                        + r
                        * (
                            _C6
                            + r
                            * (_C7 + r * (_C8 + r * (_C9 + r * (_C10 + r * (_C11 + r * (_C12 + r * _C13))))))
                        )
                    )
                )
            )
        )
    )
    s = _i2f(((_f2i(kr) - _ROUND_BITS) + 1023) << 52)
    out = s * p + s
    return out if b > 0.0 else 0.0
