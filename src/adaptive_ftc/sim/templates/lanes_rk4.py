"""RK4 of W members in SIMD lanes (template of ``sim/lanes.py``, issue 29).

The text after the marker is pasted into each generated lane module, after its row constants
and its lane ``rhs(B, tt, y, dy)``: the same classical RK4 as ``templates/rk4.py``, step for
step, on W lanes that advance in lockstep of step count, each on its own break times and step
sizes, with its own records, divergence check, status and counts. The placeholders above the
marker exist only so this file imports and lints on its own.
"""

# ruff: noqa: F811
import math

import numpy as np
from numba import njit as hot
from numba import njit as inl

# placeholders: each lane module defines its width, sizes and the first row of each quantity
W = NY = NENV = ENV = 1
CR = Y = K1 = K2 = K3 = K4 = YT = YN = FE = DY = 0
T = TM = T1 = HH = H2 = H6 = TIN = ACT = BAD = REFT = FK = FC = 0


def rhs(B, tt, y, dy):  # placeholder: the lane module's right-hand side
    raise NotImplementedError


# --- template: begin ---
@hot
def rhs_rows(B):
    """The rhs on rows TIN, YT -> DY (compiled once, called by every stage)."""
    rhs(B, TIN, YT, DY)


@inl
def stage(B, tt, y, dy):
    """The rhs at the times of row tt and the state in rows y.. into rows dy.. (copies)."""
    for w in range(W):
        B[TIN * W + w] = B[tt * W + w]
    if y != YT:
        for i in range(NY * W):
            B[YT * W + i] = B[y * W + i]
    rhs_rows(B)
    for i in range(NY * W):
        B[dy * W + i] = B[DY * W + i]


@inl
def first_bad(B, row, w, bound):
    """The single run's first_bad of lane w's state in rows row..: the first state not below
    bound (nan included), else the first plant state outside the envelope; -1: none."""
    for i in range(NY):
        if not (abs(B[(row + i) * W + w]) < bound):
            return i
    for i in range(NENV):
        if not (abs(B[(row + i) * W + w]) <= B[(CR + ENV + i) * W + w]):
            return i
    return -1


@inl
def enter(B, w, ph, brk, fkind, fcon, dt, a, b, tol, nst, h):
    """Lane w enters interval ph: its ends, tolerance, steps, step and failure rows."""
    a[w] = brk[w, ph]
    b[w] = brk[w, ph + 1]
    tol[w] = 1e-9 * max(1.0, abs(b[w]))
    nst[w] = max(1, int(math.ceil((b[w] - a[w]) / dt - 1e-9)))
    h[w] = (b[w] - a[w]) / nst[w]
    for j in range(fkind.shape[2]):
        B[(FK + j) * W + w] = fkind[w, ph, j]
        for k in range(5):
            B[(FC + 5 * j + k) * W + w] = fcon[w, ph, j, k]


@hot
def run_group(
    B,
    y0,
    brk,
    nph,
    fkind,
    fcon,
    dt,
    t_rec,
    n_rec,
    bound,
    out_Y,
    out_ph,
    status,
    nrec_out,
    t_stop,
    bad_out,
    stats,
    ph,
    st,
    nst,
    a,
    b,
    h,
    tol,
    r,
    active,
):
    """RK4 of the W lanes in lockstep of step count, each on its own break times and steps.

    B: the lane buffer (its constant rows CR.. filled by the caller); y0[W, NY]; brk[W, :],
    nph[W]: break times and intervals; fkind[W, nph, M] (-1 healthy, 0 affine, 1 incipient)
    and fcon[W, nph, M, 5]: the failure of each actuator per interval; t_rec[W, :], n_rec[W]:
    record times; out_Y[W, rows, NY], out_ph[W, rows]: records (and the state where a lane
    stopped in the row after its last record); status[W] (0 finished, 1 diverged), nrec_out,
    t_stop, bad_out[W]; stats[W, 5] as the single run's. The rest: per-lane scratch."""
    for w in range(W):
        B[REFT * W + w] = np.nan  # no reference time yet (strict IEEE: nan != t)
        B[ACT * W + w] = 1.0
        for i in range(NY):
            B[(Y + i) * W + w] = y0[w, i]
        status[w] = 0
        ph[w] = 0
        st[w] = 0
        r[w] = 0
        active[w] = True
        for k in range(5):
            stats[w, k] = 0
        bad = first_bad(B, Y, w, bound)
        if bad >= 0:  # the initial state itself is bad
            status[w] = 1
            t_stop[w] = brk[w, 0]
            bad_out[w] = bad
            active[w] = False
            B[ACT * W + w] = 0.0
            if out_Y.shape[1] > 0:
                for i in range(NY):
                    out_Y[w, 0, i] = B[(Y + i) * W + w]
            continue
        enter(B, w, 0, brk, fkind, fcon, dt, a, b, tol, nst, h)
        while r[w] < n_rec[w] and t_rec[w, r[w]] <= a[w] + tol[w]:
            for i in range(NY):
                out_Y[w, r[w], i] = B[(Y + i) * W + w]
            out_ph[w, r[w]] = 0
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
        stage(B, T, Y, K1)
        for i in range(NY):
            for w in range(W):
                B[(YT + i) * W + w] = B[(Y + i) * W + w] + B[H2 * W + w] * B[(K1 + i) * W + w]
        stage(B, TM, YT, K2)
        for i in range(NY):
            for w in range(W):
                B[(YT + i) * W + w] = B[(Y + i) * W + w] + B[H2 * W + w] * B[(K2 + i) * W + w]
        stage(B, TM, YT, K3)
        for i in range(NY):
            for w in range(W):
                B[(YT + i) * W + w] = B[(Y + i) * W + w] + B[HH * W + w] * B[(K3 + i) * W + w]
        stage(B, T1, YT, K4)
        for i in range(NY):
            for w in range(W):
                B[(YN + i) * W + w] = B[(Y + i) * W + w] + B[H6 * W + w] * (
                    B[(K1 + i) * W + w]
                    + 2.0 * B[(K2 + i) * W + w]
                    + 2.0 * B[(K3 + i) * W + w]
                    + B[(K4 + i) * W + w]
                )
        # divergence of every lane at once (a select per state), then per lane
        for w in range(W):
            B[BAD * W + w] = 0.0
        for i in range(NY):
            for w in range(W):
                ok = abs(B[(YN + i) * W + w]) < bound  # False for nan too
                B[BAD * W + w] = B[BAD * W + w] if ok else 1.0
        for i in range(NENV):
            for w in range(W):
                ok = abs(B[(YN + i) * W + w]) <= B[(CR + ENV + i) * W + w]
                B[BAD * W + w] = B[BAD * W + w] if ok else 1.0
        need_fe = False
        for w in range(W):
            if not active[w]:
                continue
            stats[w, 0] += 1
            stats[w, 2] += 4
            if B[BAD * W + w] != 0.0:  # this lane stops here, the others go on
                status[w] = 1
                t_stop[w] = B[T1 * W + w]
                bad_out[w] = first_bad(B, YN, w, bound)
                active[w] = False
                B[ACT * W + w] = 0.0
                if r[w] < out_Y.shape[1]:
                    for i in range(NY):
                        out_Y[w, r[w], i] = B[(YN + i) * W + w]
                continue
            t1 = B[T1 * W + w]
            last = ph[w] == nph[w] - 1 and st[w] == nst[w] - 1
            limit = t1 + tol[w] if last else t1 - tol[w]
            rr = r[w]
            while rr < n_rec[w] and t_rec[w, rr] < limit:
                if abs(t_rec[w, rr] - t1) > tol[w]:
                    need_fe = True
                rr += 1
        if need_fe:
            stage(B, T1, YN, FE)
        for w in range(W):
            if not active[w]:
                continue
            t = B[T * W + w]
            t1 = B[T1 * W + w]
            hh = B[HH * W + w]
            last = ph[w] == nph[w] - 1 and st[w] == nst[w] - 1
            limit = t1 + tol[w] if last else t1 - tol[w]
            have_end = False
            while r[w] < n_rec[w] and t_rec[w, r[w]] < limit:
                tr = t_rec[w, r[w]]
                if abs(tr - t1) <= tol[w]:
                    for i in range(NY):
                        out_Y[w, r[w], i] = B[(YN + i) * W + w]
                else:  # cubic Hermite between (t, Y, k1) and (t1, yn, fe), as the single run
                    if not have_end:
                        stats[w, 2] += 1
                        have_end = True
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
                out_ph[w, r[w]] = ph[w]
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
                while r[w] < n_rec[w] and t_rec[w, r[w]] <= t_end + 1e-9 * max(1.0, abs(t_end)):
                    for i in range(NY):
                        out_Y[w, r[w], i] = B[(Y + i) * W + w]
                    out_ph[w, r[w]] = nph[w] - 1
                    r[w] += 1
                t_stop[w] = t_end
                active[w] = False
                B[ACT * W + w] = 0.0
                continue
            enter(B, w, ph[w], brk, fkind, fcon, dt, a, b, tol, nst, h)
            while r[w] < n_rec[w] and t_rec[w, r[w]] <= a[w] + tol[w]:
                for i in range(NY):
                    out_Y[w, r[w], i] = B[(Y + i) * W + w]
                out_ph[w, r[w]] = ph[w]
                r[w] += 1
    for w in range(W):
        nrec_out[w] = r[w]
