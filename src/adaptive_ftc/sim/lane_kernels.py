"""Call-free ``exp`` and ``tanh`` for the lane modules' vector kernels (issue 29, stage 1b).

libm's ``exp`` and ``tanh`` are scalar calls: in a lane loop they stay one call per lane and
stop the vectoriser. These are written in arithmetic alone (no call, no branch LLVM cannot turn
into a select), so a lane loop that calls them vectorises across lanes. They are not libm: exp
is within 1 ulp of libm's on [-700, 700] (mean 0.10 ulp), tanh within 2 ulp
(``benchmarks/lanes_prototype.py`` measured both), so a lane module that uses them
(``kernels="vector"`` in :mod:`adaptive_ftc.sim.lanes`) is no longer bit-identical to the
single run: about 1e-14 of the signal scale over a 120 s run (docs/performance.md).

Used only by generated lane modules (imported there, jitted inline; this module's source keys
their disk cache).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir as llvm_ir
from numba import njit, types
from numba.extending import intrinsic

__all__ = ["vexp", "vtanh"]

# Cody-Waite split of ln 2 (fdlibm): n * LN2_HI is exact for |n| < 2^20
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
LOG2E = 1.44269504088896338700e00
EXP_HI = 709.0  # above: clamped (exp overflows at 709.78)
EXP_LO = -708.0  # below: 0 (the subnormal range is not reproduced)
# 1/k! for k = 13..0 (Horner, highest first); degree 13 on |r| <= ln2/2: truncation 4e-18
C13, C12, C11, C10, C9, C8, C7, C6, C5, C4, C3, C2, C1, C0 = (
    1.0 / math.factorial(k) for k in range(13, -1, -1)
)
# Cephes: tanh on |x| <= 0.625 as x + x^3 P(x^2) / Q(x^2)
TP0, TP1, TP2 = -9.64399179425052238628e-1, -9.92877231001918586564e1, -1.61468768441708447952e3
TQ0, TQ1, TQ2 = 1.12811678491632931402e2, 2.23548839060100448583e3, 4.84406305325125486048e3


@intrinsic
def as_double(typingctx, bits):
    """Reinterpret the bits of an int64 as a float64 (an LLVM bitcast; vectorises)."""
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], llvm_ir.DoubleType())

    return sig, codegen


_inl = njit(nogil=True, error_model="numpy", inline="always")  # pasted into the lane loops


@_inl
def vexp(x):
    """exp(x) without calls: Cody-Waite reduction, degree-13 Taylor polynomial, 2^n from the
    exponent bits (0 below -708; above 709 the value at 709, not inf: the lanes call it on
    arguments <= 40 only)."""
    v = max(min(x, EXP_HI), EXP_LO)
    n = math.floor(v * LOG2E + 0.5)
    z = (v - n * LN2_HI) - n * LN2_LO
    p = C13
    p = p * z + C12
    p = p * z + C11
    p = p * z + C10
    p = p * z + C9
    p = p * z + C8
    p = p * z + C7
    p = p * z + C6
    p = p * z + C5
    p = p * z + C4
    p = p * z + C3
    p = p * z + C2
    p = p * z + C1
    p = p * z + C0
    p = p * as_double((np.int64(n) + 1023) << 52)  # times 2^n
    return p if x >= EXP_LO else (0.0 if x < EXP_LO else x)  # nan stays nan


@_inl
def vtanh(x):
    """tanh(x) without calls, as Cephes: x + x^3 P/Q on |x| <= 0.625, else from exp (both
    computed, one selected)."""
    ax = min(abs(x), 20.0)
    big = 1.0 - 2.0 / (vexp(2.0 * ax) + 1.0)
    big = big if x >= 0.0 else -big
    z = x * x
    small = x + x * z * ((TP0 * z + TP1) * z + TP2) / (((z + TQ0) * z + TQ1) * z + TQ2)
    return small if ax <= 0.625 else big
