"""Prototype (issue 29): members of hypersonic-direct-s1 in SIMD lanes, against single runs and C.

Run: ``python benchmarks/lanes_prototype.py [--n 32] [--widths 4,8,16] [--rounds 3] [--seed 0]
[--diverging 2] [--variants a,b,c:8,d:8,e:8,f,g]`` (a variant's own widths after a colon:
``g:8+16``). The measurements in docs/performance.md ("SIMD lanes: measured potential") came
from ``--n 32 --rounds 5 --diverging 0 --variants a,b,c:8,d:8,e:8,f,g:8+16`` (time the
members without diverging ones: the C has no envelope check, so it runs those on).

Not library code: a hand-written, lane-parallel (struct-of-arrays) form of the §2.3 direct loop
(plant (2.50), 5 x 5 raw fuzzy basis (2.40), control (2.22), robust term (2.20), theta law (2.29),
two elevators with proportional allocation (3.14)), RK4 with ``dt = 1e-3`` over 120 s, written to
measure what an ensemble engine could buy before anyone turns the parts of ``sim/parts`` into lane
emitters.

Layout: every quantity is a row of ``W`` lanes and every statement of the right-hand side a loop
over the lanes, so that LLVM vectorises it across members. All rows (state, stages, work, times,
failure maps) live in ONE array ``B[N_B * W]`` at constant offsets (``B[(ROW + i) * W + w]``):
with separate arrays LLVM cannot prove that a store to one leaves a load from another unchanged,
and nothing vectorises. ``W`` is a compile-time constant (a closure variable of
:func:`build_engine`), so LLVM unrolls the lane loops and its SLP vectoriser (off in numba by
default, switched on below) turns them into vector instructions.

Failures (loss of effectiveness, bias, stuck, affine; drawn as in ``bench_batch.py``) are, per lane
and per failure interval, an affine map ``u_f = a u + b`` (healthy: ``a = 1, b = 0``), so the
failure is branch-free across lanes. Every lane has its own break times (onsets, recoveries): lanes
advance in lockstep of *step count*, each with its own interval, step size ``h`` and time, exactly
the steps of its single run (``integrate_rk4``: ``ceil((b - a) / dt - 1e-9)`` steps per interval,
the last landing on ``b``). A lane that has finished idles with ``h = 0`` until the group is done
(at most a few steps: each break adds at most one). Records on the 0.01 s grid per lane (the
step's end state or the cubic Hermite interpolant, as the library does); divergence
(``|y| >= 1e8`` or alpha outside the plant's envelope) stops one lane, not the group. The last
group is filled up with copies of the first member (their time counts; their results are
dropped).

Variants (each for the widths asked for):

- ``a``: scalar ``math.exp`` (libm) inside the lane loops, strict IEEE (no fastmath). No SVML on
  this machine, so LLVM cannot vectorise the exp; everything else may vectorise.
- ``b``: a vectorisable exp written here (Cody-Waite range reduction, degree-13 Taylor polynomial,
  ``2^n`` built from the exponent bits by an LLVM bitcast), strict IEEE otherwise.
- ``c``: ``a`` with ``fastmath=True``.
- ``d``: ``b`` with ``fastmath=True``.
- ``e``: ``b`` with the rhs pasted into its five call sites (no copies; 2-3x the compile time).
- ``f``: ``b`` with tanh, sin and cos written here too (fdlibm / Cephes kernels): no libm call
  left in the rhs.
- ``g``: ``f`` pasted (as ``e``) and with ``fastmath={"contract"}`` (fused multiply-adds only;
  NaN, infinities and the order of operations kept).

``tanh`` (one per rhs and lane) and the reference's ``sin``/``cos`` (cached per lane and time, two
times per step) stay scalar libm calls in every variant but ``f`` and ``g``.

Timing (single thread, one process, interleaved rounds; per member = group time / members):
the same members run as single runs of the library (``CompiledLoop.integrate()``: integration
with recording, no signals), through the C reference in ``integrate`` mode
(``c/hypersonic_loop.c``, one process per member) and through every lane engine (group
allocation, integration and recording). Prints min and median per member of the CPU time (this
process's ``time.process_time``; the C children's user + system time, which includes their
start, about 1 ms) and of the wall time (the library's ``Integration.wall``, the C's own
``elapsed``), and the ratios to C and to the library's single run. On a shared machine the CPU
time is the steadier figure (time spent waiting for a core is not in it).

Agreement: every lane's recorded trajectory (12001 x 27) against its own single run, max |diff|
per state divided by that state's max |value| in the single run (the signal scale), and the same
status and number of records; ``--diverging`` members (both elevators reversed) leave the
plant's envelope among the others, so their lanes stop early. Exit status 1 when any variant is
not within 1e-10 (issue 29's demand). Also prints how the difference grows over the 120 s and
the ulps of the prototype's exp, tanh, sin and cos against libm.

Not library code: the script sets ``NUMBA_SLP_VECTORIZE=1`` for its own process (see the top of
the file) and compiles its engines in memory (15-100 s each on a loaded 2-core machine).
"""

from __future__ import annotations

import os

# numba leaves LLVM's SLP vectoriser off by default; the lanes need it (the loop vectoriser does
# not touch loops of a constant W, which LLVM unrolls first). Before numba is imported.
os.environ.setdefault("NUMBA_SLP_VECTORIZE", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402
from _cref import CReferenceError, build, rk4_scenario, run_single  # noqa: E402
from bench_batch import draw_failures  # noqa: E402
from llvmlite import ir as llvm_ir  # noqa: E402
from numba import njit, types  # noqa: E402
from numba.extending import intrinsic  # noqa: E402

from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck  # noqa: E402
from adaptive_ftc.sim.engine import CompiledLoop  # noqa: E402

SCENARIO = "hypersonic-direct-s1"
NY = 27  # alpha, q, theta_1..theta_25
TOL_EXACT = 1e-10  # issue 29: every member within 1e-10 of its own single run
GROWTH_TIMES = (1.0, 10.0, 30.0, 60.0, 120.0)

# rows of the lane buffer B[N_B * W]: every lane quantity is one row of W numbers, all in one
# array at constant offsets, so LLVM can prove that the rows a statement reads and writes are
# disjoint and vectorise it across lanes (separate arrays may alias: nothing vectorises)
Y, K1, K2, K3, K4, YT, YN, FE, DY = (NY * i for i in range(9))  # state, stages, stage state...
T, TM, T1, HH, H2, H6, TIN = range(9 * NY, 9 * NY + 7)  # per lane t, t+h/2, t+h, h, h/2, h/6
FA, FB = 9 * NY + 7, 9 * NY + 9  # failure map u_f = a u + b per elevator (2 rows each)
ACT, BAD = 9 * NY + 11, 9 * NY + 12  # 1.0 while the lane runs; 1.0 where its step diverged
WK = 9 * NY + 13  # work rows (relative to WK):
R0, R1, R2, REFT = 0, 1, 2, 3  # reference y_d, y_d', y_d'' and the time they belong to
ED, S, SD, QQ, U0 = 4, 5, 6, 7, 8  # e', s (2.18), s', q (2.20), u0 = phi^T theta (2.22)
ARG = 9  # 10 rows: exp arguments of the memberships
MU = 19  # 10 rows: memberships
PHI = 29  # 25 rows: firing strengths
N_B = WK + PHI + 25
NO_TIME = -1e300  # the reference cache holds no time yet

# Cody-Waite split of ln 2 (fdlibm): n * LN2_HI is exact for |n| < 2^20
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
LOG2E = 1.44269504088896338700e00
EXP_HI = 709.0  # above: clamped (exp overflows at 709.78)
EXP_LO = -708.0  # below: 0 (the subnormal range is not reproduced)
# 1/k! for k = 13..0 (Horner, highest first); degree 13 on |r| <= ln2/2: truncation 4e-18
TAYLOR = tuple(1.0 / math.factorial(k) for k in range(13, -1, -1))


@intrinsic
def as_double(typingctx, bits):
    """Reinterpret the bits of an int64 as a float64 (LLVM bitcast; vectorises)."""
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], llvm_ir.DoubleType())

    return sig, codegen


# fdlibm: pi/2 in two parts (n * PIO2_1 exact for |n| < 2^20) and the sin/cos kernels on
# [-pi/4, pi/4]; Cephes: tanh on |x| <= 0.625 as x + x^3 P(x^2) / Q(x^2)
TWO_OVER_PI = 6.36619772367581382433e-01
PIO2_1 = 1.57079632673412561417e00
PIO2_1T = 6.07710050650619224932e-11
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
TP0, TP1, TP2 = -9.64399179425052238628e-1, -9.92877231001918586564e1, -1.61468768441708447952e3
TQ0, TQ1, TQ2 = 1.12811678491632931402e2, 2.23548839060100448583e3, 4.84406305325125486048e3


def build_engine(
    W: int,
    vector_exp: bool,
    fastmath: bool | set[str],
    shared_rhs: bool = True,
    vector_trig: bool = False,
):
    """Compile the lane engine for ``W`` lanes: returns ``run_group`` (see its docstring) and
    ``kernels`` (the exp, tanh, sin and cos written here, for the accuracy check).

    ``vector_exp``: the call-free exp for the fuzzy basis (else libm's, a call per lane);
    ``fastmath``: numba's option (True, or a set of LLVM flags such as ``{"contract"}``);
    ``shared_rhs``: one compiled rhs reading rows ``TIN, YT`` and writing ``DY`` (the stages
    copy their time in and the derivative out); else the rhs is pasted into each of its five
    call sites with their own rows (no copies, about 5 times the code and compile time).
    ``vector_trig``: tanh, sin and cos written here too (no libm call left in the rhs)."""
    opts = dict(nogil=True, error_model="numpy", fastmath=fastmath)
    inl = njit(inline="always", **opts)
    c13, c12, c11, c10, c9, c8, c7, c6, c5, c4, c3, c2, c1, c0 = TAYLOR

    @inl
    def vexp(x):
        """exp of one number without calls (the polynomial of exp_rows; inlined, vectorises)."""
        v = max(min(x, EXP_HI), EXP_LO)
        n = math.floor(v * LOG2E + 0.5)
        z = (v - n * LN2_HI) - n * LN2_LO
        p = c13
        p = p * z + c12
        p = p * z + c11
        p = p * z + c10
        p = p * z + c9
        p = p * z + c8
        p = p * z + c7
        p = p * z + c6
        p = p * z + c5
        p = p * z + c4
        p = p * z + c3
        p = p * z + c2
        p = p * z + c1
        p = p * z + c0
        p = p * as_double((np.int64(n) + 1023) << 52)  # times 2^n
        return p if x >= EXP_LO else 0.0

    if vector_exp:

        @inl
        def exp_rows(B, src, dst, nrow):
            """B rows dst.. = exp(B rows src..): no calls, so the lanes vectorise."""
            for r in range(nrow):
                for w in range(W):
                    x = B[(src + r) * W + w]
                    v = max(min(x, EXP_HI), EXP_LO)
                    n = math.floor(v * LOG2E + 0.5)
                    z = (v - n * LN2_HI) - n * LN2_LO
                    p = c13
                    p = p * z + c12
                    p = p * z + c11
                    p = p * z + c10
                    p = p * z + c9
                    p = p * z + c8
                    p = p * z + c7
                    p = p * z + c6
                    p = p * z + c5
                    p = p * z + c4
                    p = p * z + c3
                    p = p * z + c2
                    p = p * z + c1
                    p = p * z + c0
                    p = p * as_double((np.int64(n) + 1023) << 52)  # times 2^n
                    B[(dst + r) * W + w] = p if x >= EXP_LO else 0.0

    else:

        @inl
        def exp_rows(B, src, dst, nrow):
            """B rows dst.. = exp(B rows src..) through libm's scalar exp (a call per lane)."""
            for r in range(nrow):
                for w in range(W):
                    B[(dst + r) * W + w] = math.exp(B[(src + r) * W + w])

    @inl
    def vsin_cos(x):
        """(sin x, cos x) without calls: fdlibm kernels after a two-part reduction by pi/2
        (enough for the |x| < 1e5 of a reference's phase)."""
        n = math.floor(x * TWO_OVER_PI + 0.5)
        r = (x - n * PIO2_1) - n * PIO2_1T
        z = r * r
        sr = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))))
        cr = 1.0 - (0.5 * z - z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6))))))
        quad = np.int64(n) & 3
        sn = sr if quad == 0 else (cr if quad == 1 else (-sr if quad == 2 else -cr))
        cs = cr if quad == 0 else (-sr if quad == 1 else (-cr if quad == 2 else sr))
        return sn, cs

    @inl
    def vtanh(x):
        """tanh x without calls, as Cephes: x + x^3 P/Q on |x| <= 0.625, else from exp (both
        computed, one selected)."""
        ax = min(abs(x), 20.0)
        big = 1.0 - 2.0 / (vexp(2.0 * ax) + 1.0)
        big = big if x >= 0.0 else -big
        z = x * x
        small = x + x * z * ((TP0 * z + TP1) * z + TP2) / (((z + TQ0) * z + TQ1) * z + TQ2)
        return small if ax <= 0.625 else big

    @njit(**opts)
    def kernels(x, out):
        """out[0..3] = exp, tanh, sin, cos of x (for the accuracy check)."""
        for i in range(x.size):
            out[0, i] = vexp(x[i])
            out[1, i] = vtanh(x[i])
            out[2, i], out[3, i] = vsin_cos(x[i])

    if vector_trig:

        @inl
        def reference(B, tt, amp, omega):
            """y_d = A sin(w t) and its derivatives for all lanes when any lane's time moved."""
            moved = False
            for w in range(W):
                moved |= B[(WK + REFT) * W + w] != B[tt * W + w]
            if not moved:
                return
            for w in range(W):
                sn, cs = vsin_cos(omega * B[tt * W + w])
                B[(WK + R0) * W + w] = amp * sn
                B[(WK + R1) * W + w] = amp * (cs * omega)
                B[(WK + R2) * W + w] = amp * (((-sn) * omega) * omega)
                B[(WK + REFT) * W + w] = B[tt * W + w]

        @inl
        def robust(B, k, k0, eps0):
            """q = s' + k s + k0 tanh(s / eps0) (2.20), tanh without calls."""
            for w in range(W):
                s = B[(WK + S) * W + w]
                B[(WK + QQ) * W + w] = B[(WK + SD) * W + w] + k * s + k0 * vtanh(s / eps0)

    else:

        @inl
        def reference(B, tt, amp, omega):
            """y_d = A sin(w t) and its derivatives, per lane whose time moved (libm)."""
            for w in range(W):
                t = B[tt * W + w]
                if B[(WK + REFT) * W + w] != t:
                    sn = math.sin(omega * t)
                    cs = math.cos(omega * t)
                    B[(WK + R0) * W + w] = amp * sn
                    B[(WK + R1) * W + w] = amp * (cs * omega)
                    B[(WK + R2) * W + w] = amp * (((-sn) * omega) * omega)
                    B[(WK + REFT) * W + w] = t

        @inl
        def robust(B, k, k0, eps0):
            """q = s' + k s + k0 tanh(s / eps0) (2.20), libm's tanh per lane."""
            for w in range(W):
                s = B[(WK + S) * W + w]
                B[(WK + QQ) * W + w] = B[(WK + SD) * W + w] + k * s + k0 * math.tanh(s / eps0)

    @inl
    def rhs(B, C, tt, y, dy):
        """Closed-loop derivative of the W members in B's rows y.. at their own times (row tt)
        into rows dy.. (rows are constants once inlined: LLVM sees disjoint slices of B)."""
        amp, omega, lam, k, k0, eps0, gamma, sigma = C[0], C[1], C[2], C[3], C[4], C[5], C[6], C[7]
        r_1, r_2 = C[8], C[9]
        p_scale, k_alpha, a2, a1, a0, k_q, q2, q1, q0, k_e = (
            C[10],
            C[11],
            C[12],
            C[13],
            C[14],
            C[15],
            C[16],
            C[17],
            C[18],
            C[19],
        )
        # reference, cached per lane while its time stays the same (k2, k3; k4 and the next k1)
        reference(B, tt, amp, omega)
        # tracking errors and filtered error (2.18)
        for w in range(W):
            e = B[(WK + R0) * W + w] - B[y * W + w]
            ed = B[(WK + R1) * W + w] - B[(y + 1) * W + w]
            B[(WK + ED) * W + w] = ed
            B[(WK + S) * W + w] = ed + lam * e
        # raw fuzzy basis (2.40): 5 memberships per input, then their products
        for l in range(5):
            cen = C[20 + l]
            spr = C[30 + l]
            for w in range(W):
                d = B[y * W + w] - cen
                B[(WK + ARG + l) * W + w] = -spr * d * d
        for l in range(5):
            cen = C[25 + l]
            spr = C[35 + l]
            for w in range(W):
                d = B[(y + 1) * W + w] - cen
                B[(WK + ARG + 5 + l) * W + w] = -spr * d * d
        exp_rows(B, WK + ARG, WK + MU, 10)
        for i in range(5):
            for j in range(5):
                for w in range(W):
                    B[(WK + PHI + 5 * i + j) * W + w] = (
                        B[(WK + MU + i) * W + w] * B[(WK + MU + 5 + j) * W + w]
                    )
        # u0 = phi^T theta (2.22)
        for w in range(W):
            B[(WK + U0) * W + w] = 0.0
        for l in range(25):
            for w in range(W):
                B[(WK + U0) * W + w] += B[(WK + PHI + l) * W + w] * B[(y + 2 + l) * W + w]
        # allocation (3.14), failures u_f = a u + b, plant (2.50)
        for w in range(W):
            u0 = B[(WK + U0) * W + w]
            uf1 = B[FA * W + w] * (0.0 + r_1 * u0) + B[FB * W + w]
            uf2 = B[(FA + 1) * W + w] * (0.0 + r_2 * u0) + B[(FB + 1) * W + w]
            usum = 0.0 + uf1 + uf2
            a = B[y * W + w]
            q = B[(y + 1) * W + w]
            xd1 = p_scale * (
                k_alpha * (a2 * a * a + a1 * a + a0)
                + k_q * q * (q2 * a * a + q1 * a + q0)
                + k_e * (usum - a)
            )
            B[dy * W + w] = q
            B[(dy + 1) * W + w] = xd1
            B[(WK + SD) * W + w] = B[(WK + R2) * W + w] - xd1 + lam * B[(WK + ED) * W + w]
        # q = s' + k s + k0 tanh(s / eps0) (2.20)
        robust(B, k, k0, eps0)
        # theta' = gamma phi q - gamma sigma theta (2.29)
        g = gamma * 1.0
        gs = gamma * sigma
        for l in range(25):
            for w in range(W):
                B[(dy + 2 + l) * W + w] = (
                    g * B[(WK + PHI + l) * W + w] * B[(WK + QQ) * W + w]
                    - gs * B[(y + 2 + l) * W + w]
                )

    if shared_rhs:

        @njit(**opts)
        def rhs_rows(B, C):
            """The rhs on rows TIN, YT -> DY (compiled once)."""
            rhs(B, C, TIN, YT, DY)

        @inl
        def stage(B, C, tt, y, dy):
            """rhs at the times of row tt and the state in rows y.. into rows dy.. (copies)."""
            for w in range(W):
                B[TIN * W + w] = B[tt * W + w]
            if y != YT:
                for i in range(NY * W):
                    B[YT * W + i] = B[y * W + i]
            rhs_rows(B, C)
            for i in range(NY * W):
                B[dy * W + i] = B[DY * W + i]

    else:

        @inl
        def stage(B, C, tt, y, dy):
            """rhs at the times of row tt and the state in rows y.. into rows dy.. (pasted)."""
            rhs(B, C, tt, y, dy)

    @njit(**opts)
    def run_group(y0, brk, nph, FA_, FB_, dt, t_rec, C, bound, out_Y, status, nrec_out):
        """RK4 of W members in lockstep of step count, each on its own break times.

        y0[27]: initial state (shared); brk[W, MAXB], nph[W]: each lane's break times and
        number of intervals; FA_, FB_[W, MAXPH, 2]: u_f = a u + b per lane, interval,
        elevator; out_Y[W, nrec, 27]: records; status[W]: 0 finished, 1 diverged;
        nrec_out[W]: records written.
        """
        nrec = t_rec.size
        B = np.zeros(N_B * W)  # every lane quantity, one row of W per number (see N_B)
        # per lane: interval, step, steps in it, its ends, step size, tolerance, record
        ph = np.zeros(W, dtype=np.int64)
        st = np.zeros(W, dtype=np.int64)
        nst = np.zeros(W, dtype=np.int64)
        a = np.empty(W)
        b = np.empty(W)
        h = np.empty(W)
        tol = np.empty(W)
        r = np.zeros(W, dtype=np.int64)
        active = np.ones(W, dtype=np.bool_)
        for w in range(W):
            B[(WK + REFT) * W + w] = NO_TIME  # not NaN: fastmath assumes there is none
            B[ACT * W + w] = 1.0
            for i in range(NY):
                B[(Y + i) * W + w] = y0[i]
            status[w] = 0
        for w in range(W):
            # a lane entering its first interval: its steps, failure map, records at its start
            a[w] = brk[w, 0]
            b[w] = brk[w, 1]
            tol[w] = 1e-9 * max(1.0, abs(b[w]))
            nst[w] = max(1, int(math.ceil((b[w] - a[w]) / dt - 1e-9)))
            h[w] = (b[w] - a[w]) / nst[w]
            for j in range(2):
                B[(FA + j) * W + w] = FA_[w, 0, j]
                B[(FB + j) * W + w] = FB_[w, 0, j]
            while r[w] < nrec and t_rec[r[w]] <= a[w] + tol[w]:
                for i in range(NY):
                    out_Y[w, r[w], i] = B[(Y + i) * W + w]
                r[w] += 1
        while True:
            n_active = 0
            for w in range(W):
                if active[w]:
                    n_active += 1
                    t = a[w] + st[w] * h[w]
                    t1 = b[w] if st[w] == nst[w] - 1 else a[w] + (st[w] + 1) * h[w]
                else:  # finished or diverged: idles with a zero step
                    t = b[w]
                    t1 = b[w]
                hh = t1 - t
                B[T * W + w] = t
                B[T1 * W + w] = t1
                B[HH * W + w] = hh
                B[H2 * W + w] = 0.5 * hh
                B[H6 * W + w] = hh / 6.0
                B[TM * W + w] = t + 0.5 * hh
            if n_active == 0:
                break
            stage(B, C, T, Y, K1)
            for i in range(NY):
                for w in range(W):
                    B[(YT + i) * W + w] = B[(Y + i) * W + w] + B[H2 * W + w] * B[(K1 + i) * W + w]
            stage(B, C, TM, YT, K2)
            for i in range(NY):
                for w in range(W):
                    B[(YT + i) * W + w] = B[(Y + i) * W + w] + B[H2 * W + w] * B[(K2 + i) * W + w]
            stage(B, C, TM, YT, K3)
            for i in range(NY):
                for w in range(W):
                    B[(YT + i) * W + w] = B[(Y + i) * W + w] + B[HH * W + w] * B[(K3 + i) * W + w]
            stage(B, C, T1, YT, K4)
            for i in range(NY):
                for w in range(W):
                    B[(YN + i) * W + w] = B[(Y + i) * W + w] + B[H6 * W + w] * (
                        B[(K1 + i) * W + w]
                        + 2.0 * B[(K2 + i) * W + w]
                        + 2.0 * B[(K3 + i) * W + w]
                        + B[(K4 + i) * W + w]
                    )
            # divergence of every lane at once (a select per state, no branch), then per lane:
            # stop a diverged one; does any record of this step need f(t1, yn)?
            for w in range(W):
                B[BAD * W + w] = 0.0
            for i in range(NY):
                for w in range(W):
                    ok = abs(B[(YN + i) * W + w]) < bound  # False for NaN too
                    B[BAD * W + w] = B[BAD * W + w] if ok else 1.0
            for i in range(2):  # the plant's envelope: |alpha| <= pi/2, |q| <= inf
                env = C[40 + i]
                for w in range(W):
                    ok = abs(B[(YN + i) * W + w]) <= env
                    B[BAD * W + w] = B[BAD * W + w] if ok else 1.0
            need_fe = False
            for w in range(W):
                if not active[w]:
                    continue
                if B[BAD * W + w] != 0.0:
                    status[w] = 1
                    active[w] = False
                    B[ACT * W + w] = 0.0
                    continue
                t1 = B[T1 * W + w]
                last = ph[w] == nph[w] - 1 and st[w] == nst[w] - 1
                limit = t1 + tol[w] if last else t1 - tol[w]
                rr = r[w]
                while rr < nrec and t_rec[rr] < limit:
                    if abs(t_rec[rr] - t1) > tol[w]:
                        need_fe = True
                    rr += 1
            if need_fe:
                stage(B, C, T1, YN, FE)
            for w in range(W):
                if not active[w]:
                    continue
                t = B[T * W + w]
                t1 = B[T1 * W + w]
                hh = B[HH * W + w]
                last = ph[w] == nph[w] - 1 and st[w] == nst[w] - 1
                limit = t1 + tol[w] if last else t1 - tol[w]
                while r[w] < nrec and t_rec[r[w]] < limit:
                    tr = t_rec[r[w]]
                    if abs(tr - t1) <= tol[w]:
                        for i in range(NY):
                            out_Y[w, r[w], i] = B[(YN + i) * W + w]
                    else:  # cubic Hermite between (t, Y, k1) and (t1, yn, fe)
                        s = (tr - t) / hh
                        s2 = s * s
                        s3 = s * s2
                        h00 = 2 * s3 - 3 * s2 + 1
                        h10 = s3 - 2 * s2 + s
                        h01 = -2 * s3 + 3 * s2
                        h11 = s3 - s2
                        for i in range(NY):
                            out_Y[w, r[w], i] = (
                                h00 * B[(Y + i) * W + w]
                                + h10 * hh * B[(K1 + i) * W + w]
                                + h01 * B[(YN + i) * W + w]
                                + h11 * hh * B[(FE + i) * W + w]
                            )
                    r[w] += 1
            for i in range(NY):
                for w in range(W):
                    if B[ACT * W + w] != 0.0:
                        B[(Y + i) * W + w] = B[(YN + i) * W + w]
            # per lane: next step, next interval, or done
            for w in range(W):
                if not active[w]:
                    continue
                st[w] += 1
                if st[w] < nst[w]:
                    continue
                ph[w] += 1
                st[w] = 0
                if ph[w] == nph[w]:
                    t_end = b[w]
                    while r[w] < nrec and t_rec[r[w]] <= t_end + 1e-9 * max(1.0, abs(t_end)):
                        for i in range(NY):
                            out_Y[w, r[w], i] = B[(Y + i) * W + w]
                        r[w] += 1
                    active[w] = False
                    B[ACT * W + w] = 0.0
                    continue
                a[w] = brk[w, ph[w]]
                b[w] = brk[w, ph[w] + 1]
                tol[w] = 1e-9 * max(1.0, abs(b[w]))
                nst[w] = max(1, int(math.ceil((b[w] - a[w]) / dt - 1e-9)))
                h[w] = (b[w] - a[w]) / nst[w]
                for j in range(2):
                    B[(FA + j) * W + w] = FA_[w, ph[w], j]
                    B[(FB + j) * W + w] = FB_[w, ph[w], j]
                while r[w] < nrec and t_rec[r[w]] <= a[w] + tol[w]:
                    for i in range(NY):
                        out_Y[w, r[w], i] = B[(Y + i) * W + w]
                    r[w] += 1
        for w in range(W):
            nrec_out[w] = r[w]

    return run_group, kernels


# ---------------------------------------------------------------------------------- members


def affine(f) -> tuple[float, float]:
    """``(a, b)`` of ``u_f = a u + b`` for a numeric, abrupt library failure."""
    if isinstance(f, LossOfEffectiveness):
        return float(f.effectiveness), 0.0
    if isinstance(f, Bias):
        return 1.0, float(f.bias)
    if isinstance(f, Stuck):
        return 0.0, float(f.value)
    if isinstance(f, Affine):
        return float(f.effectiveness), float(f.bias)
    raise TypeError(f"the prototype has no lane form of {type(f).__name__}")


def phases(failures, t0: float, tf: float):
    """Break times and ``(a, b)`` per interval and elevator (as FailureSchedule / the C)."""
    ts = {t0, tf}
    for f in failures:
        for v in (f.onset, f.recovery):
            if v is not None and t0 < v < tf:
                ts.add(float(v))
    brk = sorted(ts)
    fa = np.ones((len(brk) - 1, 2))
    fb = np.zeros((len(brk) - 1, 2))
    for k in range(len(brk) - 1):
        mid = 0.5 * (brk[k] + brk[k + 1])
        for f in failures:
            rec = math.inf if f.recovery is None else f.recovery
            if f.onset <= mid < rec:
                fa[k, f.actuator - 1], fb[k, f.actuator - 1] = affine(f)
    return brk, fa, fb


def constants(asm) -> np.ndarray:
    """The shared numbers of the loop, read from the library's LoopData (see ``rhs``)."""
    c, lay = asm.data.c, asm.layout.params
    take = lambda name: c[lay[name]]  # noqa: E731
    out = np.zeros(42)
    out[0:2] = c[0:2]  # the reference's lifted constants: amplitude, omega (y_d = A sin(w t))
    out[2], out[3], out[4], out[5] = take("lam")[0], take("k")[0], take("k0")[0], take("eps0")[0]
    out[6:8] = take("gains")  # gamma, sigma
    out[8:10] = take("R")  # proportional allocation b_1, b_2
    out[10:20] = take("plant")
    out[20:30] = take("centers")
    out[30:40] = take("spread")
    out[40:42] = take("envelope")  # |alpha|, |q| bounds of the plant's physical envelope
    return out


class Group:
    """Packed inputs of ``n`` members for lane groups of width ``W``."""

    def __init__(self, members, t0, tf):
        per = [phases(f, t0, tf) for f in members]
        self.n = len(members)
        maxb = max(len(p[0]) for p in per)
        self.brk = np.zeros((self.n, maxb))
        self.nph = np.zeros(self.n, dtype=np.int64)
        self.FA = np.ones((self.n, maxb - 1, 2))
        self.FB = np.zeros((self.n, maxb - 1, 2))
        for m, (brk, fa, fb) in enumerate(per):
            self.brk[m, : len(brk)] = brk
            self.nph[m] = len(brk) - 1
            self.FA[m, : len(fa)] = fa
            self.FB[m, : len(fb)] = fb


def run_lanes(engine, W, grp: Group, y0, dt, t_rec, C, bound):
    """All members through ``engine`` in groups of ``W`` (the last group filled up with copies
    of the first member, their results dropped): ``(records[n, nrec, 27], nrec[n],
    status[n])``."""
    n = grp.n
    total = -(-n // W) * W
    pick = np.r_[np.arange(n), np.zeros(total - n, dtype=np.int64)]
    brk, nph, fa, fb = grp.brk[pick], grp.nph[pick], grp.FA[pick], grp.FB[pick]
    out = np.empty((total, t_rec.size, NY))
    nrec = np.zeros(total, dtype=np.int64)
    status = np.zeros(total, dtype=np.int64)
    for g in range(0, total, W):
        s = slice(g, g + W)
        engine(y0, brk[s], nph[s], fa[s], fb[s], dt, t_rec, C, bound, out[s], status[s], nrec[s])
    return out[:n], nrec[:n], status[:n]


# ---------------------------------------------------------------------------------- checks


def ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance in units in the last place between doubles (of the same sign; 0 and -0 apart
    by one)."""
    ia, ib = a.view(np.int64), b.view(np.int64)
    ia = np.where(ia < 0, np.int64(-(2**63)) - ia, ia)  # order the negatives too
    ib = np.where(ib < 0, np.int64(-(2**63)) - ib, ib)
    return np.abs(ia - ib)


@njit
def _libm(x, out):
    for i in range(x.size):
        out[0, i] = math.exp(x[i])
        out[1, i] = math.tanh(x[i])
        out[2, i] = math.sin(x[i])
        out[3, i] = math.cos(x[i])


KERNELS = ("exp", "tanh", "sin", "cos")


def kernel_ulps(kernels, lo: float, hi: float, n: int = 1 << 18) -> list[tuple[int, float]]:
    """Max and mean ulps of the prototype's exp, tanh, sin, cos against libm on ``n`` points
    in [lo, hi]."""
    x = np.random.default_rng(1).uniform(lo, hi, n)
    ref = np.empty((4, n))
    got = np.empty((4, n))
    _libm(x, ref)
    kernels(x, got)
    out = []
    for k in range(4):
        u = ulps(got[k], ref[k])
        out.append((int(u.max()), float(u.mean())))
    return out


def relative_diff(lanes: np.ndarray, single: np.ndarray) -> float:
    """max over states of max |lane - single| / max |single| (the state's signal scale)."""
    scale = np.maximum(np.max(np.abs(single), axis=0), 1e-300)
    return float(np.max(np.max(np.abs(lanes - single), axis=0) / scale))


# ---------------------------------------------------------------------------------- main


def _children_cpu() -> float:
    """CPU seconds (user + system) of the finished child processes (the C runs) so far."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--n", type=int, default=32, help="members (default 32)")
    ap.add_argument("--widths", default="4,8,16", help="lane widths W (default 4,8,16)")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the failure draws (default 0)")
    ap.add_argument(
        "--diverging",
        type=int,
        default=2,
        help="members that diverge (both elevators reversed), among the others (default 2)",
    )
    ap.add_argument(
        "--variants",
        default="a,b,c:8,d:8,e:8,f,g",
        help="variants, each with its own widths after a colon (8+16) or all of --widths "
        "(default a,b,c:8,d:8,e:8,f,g)",
    )
    args = ap.parse_args()
    known = {  # (vector exp, fastmath, shared rhs, vector tanh/sin/cos)
        "a": (False, False, True, False),
        "b": (True, False, True, False),
        "c": (False, True, True, False),
        "d": (True, True, True, False),
        "e": (True, False, False, False),
        "f": (True, False, True, True),
        "g": (True, {"contract"}, False, True),
    }
    try:
        widths = [int(v) for v in args.widths.split(",")]
        plan = []
        for item in args.variants.split(","):
            v, _, ws = item.partition(":")
            plan.append((v, [int(w) for w in ws.split("+")] if ws else widths))
    except ValueError:
        plan = []
    if (
        args.n < 1
        or args.rounds < 1
        or not plan
        or any(v not in known or min(ws) < 1 for v, ws in plan)
    ):
        print(
            "error: --n, --rounds and --widths must be positive integers, --variants a list "
            "of a..g, each optionally with widths (b:8+16)"
        )
        return 2
    try:
        exe = build()
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"load: {load}")

    sc = rk4_scenario(SCENARIO)
    loop, solver = sc.loop, sc.solver
    rng = np.random.default_rng(args.seed)
    members = [draw_failures(rng, loop.t_final) for _ in range(args.n)]
    diverging = sorted({(k * args.n) // max(1, args.diverging) + 1 for k in range(args.diverging)})
    for m in diverging:  # both elevators reversed: alpha leaves its envelope, the lane stops
        if m < args.n:
            onset = float(np.round(rng.uniform(10.0, 60.0), 3))
            members[m] = tuple(
                Affine(actuator=j, onset=onset + 5.0 * (j - 1), effectiveness=-1.0, bias=0.0)
                for j in (1, 2)
            )
    compiled = [CompiledLoop.build(replace(loop, failures=f), solver) for f in members]
    grp = Group(members, loop.t0, loop.t_final)
    for m, cl in enumerate(compiled):  # the prototype's intervals are the library's
        assert tuple(grp.brk[m, : grp.nph[m] + 1]) == tuple(cl.asm.breakpoints), m
    asm = compiled[0].asm
    C = constants(asm)
    y0 = np.array(asm.y0, dtype=float)
    t_rec = compiled[0].t_rec
    dt, bound = float(solver.dt), float(solver.divergence_bound)
    warnings.simplefilter("ignore")

    # single runs (reference trajectories; compile or load the library's loop first)
    singles, single_status = [], []
    for cl in compiled:
        run = cl.integrate()
        singles.append(run.Y[: run.nrec].copy())
        single_status.append(0 if run.status == "completed" else 1)
    n_div = sum(single_status)

    # compile every engine, check its exp and its agreement
    engines: dict[tuple[str, int], object] = {}
    compile_s: dict[tuple[str, int], float] = {}
    t_compile = time.perf_counter()
    for v, ws in plan:
        for W in ws:
            t0 = time.perf_counter()
            engines[v, W] = build_engine(W, *known[v])
            # numba compiles on the first call: a one-member group over 1 ms
            one = Group([()], 0.0, 1e-3)
            run_lanes(engines[v, W][0], W, one, y0, dt, t_rec[:1], C, bound)
            compile_s[v, W] = time.perf_counter() - t0
    print(
        f"{SCENARIO}: {args.n} members (failures drawn as bench_batch.py, seed {args.seed}; "
        f"{n_div} of them diverge), RK4 dt {dt:g}, {loop.t_final:g} s, records every "
        f"{solver.record_dt:g} s"
    )
    ok = True
    print(
        "agreement with each member's own single run (max |diff| / signal scale, all members"
        " and states; then the growth over time for the largest width):"
    )
    for v, ws in plan:
        for W in ws:
            run_group, _ = engines[v, W]
            out, nrec, status = run_lanes(run_group, W, grp, y0, dt, t_rec, C, bound)
            worst, same = 0.0, True
            for m in range(args.n):
                ref = singles[m]
                if nrec[m] != ref.shape[0] or status[m] != single_status[m]:
                    print(
                        f"  {v} W={W}: member {m} recorded {nrec[m]} rows, status "
                        f"{status[m]}; its single run {ref.shape[0]}"
                    )
                    ok = False
                    continue
                got = out[m, : nrec[m]]
                worst = max(worst, relative_diff(got, ref))
                same = same and bool(np.array_equal(got, ref))
            limit = TOL_EXACT
            verdict = "ok" if worst <= limit else "FAILED"
            ok = ok and worst <= limit
            note = "bit-identical" if same else f"{worst:.2e}"
            print(
                f"  variant {v}, W = {W:2d}: {note} (limit {limit:g}: {verdict}); compiled in "
                f"{compile_s[v, W]:.1f} s"
            )
            if W == ws[-1]:
                growth = []
                for tg in GROWTH_TIMES:
                    k = int(np.searchsorted(t_rec, tg + 1e-9))
                    cut = [min(k, len(ref)) for ref in singles]  # diverged runs end early
                    growth.append(
                        max(
                            relative_diff(out[m, : cut[m]], singles[m][: cut[m]])
                            for m in range(args.n)
                            if cut[m] > 0
                        )
                    )
                pairs = zip(GROWTH_TIMES, growth, strict=True)
                print("      up to t = " + ", ".join(f"{tg:g} s: {g:.1e}" for tg, g in pairs))
        if v == "e":
            continue  # the same kernels as b
        if known[v][0]:
            _, kernels = engines[v, ws[0]]
            names = KERNELS if known[v][3] else KERNELS[:1]
            ranges = {"exp": [(-4.0, 0.0), (-700.0, 700.0)], "tanh": [(-20.0, 20.0)]}
            ranges.update(sin=[(0.0, 24.0)], cos=[(0.0, 24.0)])  # 24 = omega t_final
            for k, name in enumerate(names):
                for lo, hi in ranges[name]:
                    mx, mean = kernel_ulps(kernels, lo, hi)[k]
                    print(
                        f"  variant {v}: its {name} vs libm on [{lo:g}, {hi:g}]: max {mx} ulp "
                        f"(mean {mean:.2f})"
                    )
    print(f"  (compiling {len(engines)} engines: {time.perf_counter() - t_compile:.1f} s)")

    # timing: interleaved rounds of C, library single runs and every engine; CPU time (this
    # process's, or the C children's) and wall time
    cpu: dict[str, list[float]] = {"C": [], "single": []}
    wall: dict[str, list[float]] = {"C": [], "single": []}
    for key in engines:
        cpu[f"{key[0]} W={key[1]}"] = []
        wall[f"{key[0]} W={key[1]}"] = []
    for _ in range(args.rounds):
        tc = 0.0
        c0 = _children_cpu()
        for f in members:
            tc += run_single(exe, mode="integrate", failures=f, read=False).elapsed[0]
        cpu["C"].append((_children_cpu() - c0) / args.n)
        wall["C"].append(tc / args.n)
        c0 = time.process_time()
        wall["single"].append(sum(cl.integrate().wall for cl in compiled) / args.n)
        cpu["single"].append((time.process_time() - c0) / args.n)
        for (v, W), (run_group, _) in engines.items():
            c0, t0 = time.process_time(), time.perf_counter()
            run_lanes(run_group, W, grp, y0, dt, t_rec, C, bound)
            cpu[f"{v} W={W}"].append((time.process_time() - c0) / args.n)
            wall[f"{v} W={W}"].append((time.perf_counter() - t0) / args.n)
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"time per member, one thread, {args.rounds} interleaved rounds; load after: {load}")
    for what, times in (("CPU time", cpu), ("wall time", wall)):
        c_min, c_med = min(times["C"]), statistics.median(times["C"])
        s_min, s_med = min(times["single"]), statistics.median(times["single"])
        print(f"  {what} (min / median):")
        print(f"  {'':10s} {'ms':>15s} {'x C':>13s} {'x single':>13s}")
        for name, xs in times.items():
            lo, med = min(xs), statistics.median(xs)
            print(
                f"  {name:10s} {1e3 * lo:6.2f} / {1e3 * med:6.2f}   {lo / c_min:5.2f} / "
                f"{med / c_med:5.2f}   {lo / s_min:5.2f} / {med / s_med:5.2f}"
            )
    if not ok:
        print("FAILED: a lane engine disagrees with the single runs")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
