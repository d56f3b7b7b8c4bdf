"""Call-free ``exp``, ``tanh``, ``sin`` and ``cos`` for the lane modules' vector kernels (issue
29, stage 1b; ``sin``/``cos`` since stage 1c).

libm's ``exp`` and ``tanh`` are scalar calls: in a lane loop they stay one call per lane and
stop the vectoriser. These are written in arithmetic alone (no call, no branch LLVM cannot turn
into a select), so a lane loop that calls them vectorises across lanes. They are not libm: exp
is within 1 ulp of libm's on [-700, 700] (mean 0.10 ulp), tanh within 2 ulp
(``benchmarks/lanes_prototype.py`` measured both), sin and cos (fdlibm kernels after a two-part
reduction by pi/2) within 1 ulp on |x| <= 1e4 (tests/test_lane_trig.py; nan beyond |x| = 1e6),
so a lane module that uses them (``kernels="vector"`` in :mod:`adaptive_ftc.sim.lanes`) is no
longer bit-identical to the single run: about 1e-14 of the signal scale over a 120 s run
(docs/performance.md).

Used only by generated lane modules (imported there, jitted inline; this module's source keys
their disk cache).
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir as llvm_ir
from numba import njit, types
from numba.extending import intrinsic

__all__ = ["vcos", "vexp", "vsin", "vtanh"]

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
# fdlibm: pi/2 in two parts (n * PIO2_1 exact for |n| < 2^20) and the sin/cos kernels on
# [-pi/4, pi/4] (k_sin.c, k_cos.c without the tail term)
TWO_OVER_PI = 6.36619772367581382433e-01
PIO2_1 = 1.57079632673412561417e00
PIO2_1T = 6.07710050650619224932e-11
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
K1, K2, K3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
TRIG_MAX = 1e6  # |x| beyond: nan (loud), not a silently inaccurate reduction
K4, K5, K6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


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


@_inl
def _quadrant(x):
    """x reduced by pi/2: (the quadrant n mod 4, sin r, cos r) of x = n pi/2 + r, |r| <= pi/4
    (accurate while |n| < 2^20; the callers give nan beyond TRIG_MAX)."""
    n = np.floor(x * TWO_OVER_PI + 0.5)  # a float (math.floor would convert to int64)
    r = (x - n * PIO2_1) - n * PIO2_1T
    z = r * r
    sr = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))))
    cr = 1.0 - (0.5 * z - z * z * (K1 + z * (K2 + z * (K3 + z * (K4 + z * (K5 + z * K6))))))
    q = np.int64(n if abs(n) <= 2.0 * TRIG_MAX else 0.0) & 3  # (no undefined conversion)
    return q, sr, cr


@_inl
def vsin(x):
    """sin(x) without calls: fdlibm's kernels after a two-part reduction by pi/2 (both
    kernels computed, the quadrant's value selected); nan for |x| > TRIG_MAX, inf and nan."""
    q, sr, cr = _quadrant(x)
    # quadrant 0: sr, 1: cr, 2: -sr, 3: -cr, as two selects on its bits (a chain of q == k
    # became a jump table per lane, which stopped the vectoriser)
    v = cr if (q & 1) != 0 else sr
    v = -v if (q & 2) != 0 else v
    return v if abs(x) <= TRIG_MAX else np.nan


@_inl
def vcos(x):
    """cos(x) without calls, as :func:`vsin`."""
    q, sr, cr = _quadrant(x)
    v = sr if (q & 1) != 0 else cr  # quadrant 0: cr, 1: -sr, 2: -cr, 3: sr
    v = -v if ((q + 1) & 2) != 0 else v
    return v if abs(x) <= TRIG_MAX else np.nan
