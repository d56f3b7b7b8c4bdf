"""Dormand-Prince 5(4) of W members in SIMD lanes (template of ``sim/lanes.py``, issue 29).

The text after the marker is pasted into each generated lane module, after its row constants
and its lane ``rhs(B, tt, y, dy)``: the library's own DOPRI5 (``templates/adaptive.py``:
``_steps`` with ``_dopri5_step``, ``_dopri5_dense``, ``_dopri5_control``, ``_dopri5_retry``,
``_h_start``, ``_err_max``, ``_record``), step for step, per lane. Every lane keeps its own
time, step size, error, ``facold``, interval, records and counts; the lanes advance in lockstep
of step *attempts*: each pass of the loop every active lane tries one step of its own size, the
six stages run for all lanes at once (rows of W), and acceptance is per lane (a rejected lane
keeps its state and retries with its smaller step, an accepted one advances). A lane entering
an interval (at the start, after a break) first takes its fresh step-size guess (two rhs
evaluations of all lanes, used by the lanes that restart). A lane whose member ends (its
end, a divergence, a step-size underflow) hands it back and takes the next member of the
caller's queue (lane refill: ``run_group`` returns after that pass and resumes where it
stopped, its state in ``B`` and the per-lane arrays), or idles with a zero step once the
queue is empty. The constants are the single run's (imported from
``templates/adaptive.py``), the operations the same in the same order: each lane's result is
its single run's, bit for bit. The placeholders above the marker exist only so this file
imports and lints on its own.
"""

# ruff: noqa: F811, I001
import math

import numpy as np
from numba import njit as hot
from numba import njit as inl

# placeholders: each lane module defines its width, sizes and the first row of each quantity
W = NY = NENV = ENV = 1
CR = Y = YN = YT = YS = F0 = K2 = K3 = K4 = K5 = K6 = K7 = DE = RC = ATOL = DY = 0
T = T1 = HH = TIN = ACT = ERR = RT = REFT = FK = FC = 0


def rhs(B, tt, y, dy):  # placeholder: the lane module's right-hand side
    raise NotImplementedError


# --- template: begin ---
from adaptive_ftc.sim.templates.adaptive import (  # noqa: E402  the single run's constants
    _A21, _A31, _A32, _A41, _A42, _A43, _A51, _A52, _A53, _A54, _A61, _A62, _A63, _A64, _A65,
    _A71, _A73, _A74, _A75, _A76, _C2, _C3, _C4, _C5, _D1, _D3, _D4, _D5, _D6, _D7, _E1, _E3,
    _E4, _E5, _E6, _E7, _UROUND, MAX_STEPS,
)  # fmt: skip


@hot
def rhs_rows(B):
    """The rhs on rows TIN, YT -> DY (compiled once, called by every stage)."""
    rhs(B, TIN, YT, DY)


@inl
def stage(B, dy):
    """The rhs at the times of row TIN and the state in rows YT.. into rows dy.. (a copy)."""
    rhs_rows(B)
    for i in range(NY * W):
        B[dy * W + i] = B[DY * W + i]


@inl
def first_bad(B, row, w, bound):
    """The single run's _first_bad of lane w's state in rows row..: the first state not below
    bound (nan included), else the first plant state outside the envelope; -1: none."""
    for i in range(NY):
        if not (abs(B[(row + i) * W + w]) < bound):
            return i
    for i in range(NENV):
        if not (abs(B[(row + i) * W + w]) <= B[(CR + ENV + i) * W + w]):
            return i
    return -1


@inl
def keep_stop(B, row, w, r, out_Y):
    """Leave lane w's state of rows row.. in its row after the last record (the single run's
    _keep_stop)."""
    if r < out_Y[w].shape[0]:
        for i in range(NY):
            out_Y[w][r, i] = B[(row + i) * W + w]


@inl
def records_at(B, w, upto, ph, t_rec, n_rec, r, out_Y, out_ph):
    """The single run's _records_at for lane w: records ``<= upto`` take its state Y."""
    o = out_Y[w]
    while r < n_rec[w] and t_rec[w, r] <= upto:
        for i in range(NY):
            o[r, i] = B[(Y + i) * W + w]
        out_ph[w, r] = ph
        r += 1
    return r


@inl
def h_start_guess(B, w, rtol, h_max, span):
    """The first half of the single run's _h_start for lane w (f(t, Y) in rows F0): the trial
    step ``h`` and ``dnf``; the trial state ``Y + h f0`` into lane w's rows YT."""
    dnf = 0.0
    dny = 0.0
    for i in range(NY):
        sk = B[(ATOL + i) * W + w] + rtol * abs(B[(Y + i) * W + w])
        dnf += (B[(F0 + i) * W + w] / sk) ** 2
        dny += (B[(Y + i) * W + w] / sk) ** 2
    dnf = math.sqrt(dnf / NY)
    dny = math.sqrt(dny / NY)
    h = 1e-6 if (dnf <= 1e-5 or dny <= 1e-5) else 0.01 * dny / dnf
    h = min(h, h_max, span)
    for i in range(NY):
        B[(YT + i) * W + w] = B[(Y + i) * W + w] + h * B[(F0 + i) * W + w]
    return h, dnf


@inl
def h_start_finish(B, w, rtol, h_max, span, h, dnf, order):
    """The second half of _h_start for lane w, with f(t + h, Y + h f0) in its rows DY."""
    der2 = 0.0
    for i in range(NY):
        sk = B[(ATOL + i) * W + w] + rtol * abs(B[(Y + i) * W + w])
        der2 += ((B[(DY + i) * W + w] - B[(F0 + i) * W + w]) / sk) ** 2
    der2 = math.sqrt(der2 / NY) / h
    der12 = max(der2, dnf)
    if not (der12 > 1e-15):
        h1 = max(1e-6, h * 1e-3)
    else:
        h1 = (0.01 / der12) ** (1.0 / order)
    h = min(100.0 * h, h1, h_max, span)
    if not (h > 0.0):
        h = min(1e-6, span)
    return h


@inl
def dopri5_stages(B):
    """One Dormand-Prince 5(4) step of every lane from (T, Y) (f in F0) over HH: the new state
    in YN, f(T1, YN) in K7, the error estimate in DE and its norm per lane in ERR (the single
    run's _dopri5_step and _err_max, the same operations per lane)."""
    for w in range(W):
        B[TIN * W + w] = B[T * W + w] + _C2 * B[HH * W + w]
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            B[(YT + i) * W + w] = B[(Y + i) * W + w] + hh * _A21 * B[(F0 + i) * W + w]
    stage(B, K2)
    for w in range(W):
        B[TIN * W + w] = B[T * W + w] + _C3 * B[HH * W + w]
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            B[(YT + i) * W + w] = B[(Y + i) * W + w] + hh * (
                _A31 * B[(F0 + i) * W + w] + _A32 * B[(K2 + i) * W + w]
            )
    stage(B, K3)
    for w in range(W):
        B[TIN * W + w] = B[T * W + w] + _C4 * B[HH * W + w]
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            B[(YT + i) * W + w] = B[(Y + i) * W + w] + hh * (
                _A41 * B[(F0 + i) * W + w] + _A42 * B[(K2 + i) * W + w] + _A43 * B[(K3 + i) * W + w]
            )
    stage(B, K4)
    for w in range(W):
        B[TIN * W + w] = B[T * W + w] + _C5 * B[HH * W + w]
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            B[(YT + i) * W + w] = B[(Y + i) * W + w] + hh * (
                _A51 * B[(F0 + i) * W + w]
                + _A52 * B[(K2 + i) * W + w]
                + _A53 * B[(K3 + i) * W + w]
                + _A54 * B[(K4 + i) * W + w]
            )
    stage(B, K5)
    for w in range(W):
        B[TIN * W + w] = B[T1 * W + w]
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            v = B[(Y + i) * W + w] + hh * (
                _A61 * B[(F0 + i) * W + w]
                + _A62 * B[(K2 + i) * W + w]
                + _A63 * B[(K3 + i) * W + w]
                + _A64 * B[(K4 + i) * W + w]
                + _A65 * B[(K5 + i) * W + w]
            )
            B[(YS + i) * W + w] = v
            B[(YT + i) * W + w] = v
    stage(B, K6)
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            v = B[(Y + i) * W + w] + hh * (
                _A71 * B[(F0 + i) * W + w]
                + _A73 * B[(K3 + i) * W + w]
                + _A74 * B[(K4 + i) * W + w]
                + _A75 * B[(K5 + i) * W + w]
                + _A76 * B[(K6 + i) * W + w]
            )
            B[(YN + i) * W + w] = v
            B[(YT + i) * W + w] = v
    stage(B, K7)
    for w in range(W):
        B[ERR * W + w] = 0.0
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            e = hh * (
                _E1 * B[(F0 + i) * W + w]
                + _E3 * B[(K3 + i) * W + w]
                + _E4 * B[(K4 + i) * W + w]
                + _E5 * B[(K5 + i) * W + w]
                + _E6 * B[(K6 + i) * W + w]
                + _E7 * B[(K7 + i) * W + w]
            )
            B[(DE + i) * W + w] = e
            y0 = B[(Y + i) * W + w]
            y1 = B[(YN + i) * W + w]
            v = abs(e) / (B[(ATOL + i) * W + w] + B[RT * W + w] * max(abs(y0), abs(y1)))
            m = B[ERR * W + w]
            B[ERR * W + w] = m if v <= m else v
    for w in range(W):
        m = B[ERR * W + w]
        B[ERR * W + w] = m if m < math.inf else math.inf


@inl
def dense(B):
    """The single run's _dopri5_dense of every lane's step: its coefficients into rows RC..
    (for all lanes at once, vectorised; read only by the accepted lanes with a record in
    their step, as the single run computes them only there)."""
    for i in range(NY):
        for w in range(W):
            hh = B[HH * W + w]
            f0 = B[(F0 + i) * W + w]
            k7 = B[(K7 + i) * W + w]
            ydiff = B[(YN + i) * W + w] - B[(Y + i) * W + w]
            bspl = hh * f0 - ydiff
            B[(RC + i) * W + w] = ydiff
            B[(RC + NY + i) * W + w] = bspl
            B[(RC + 2 * NY + i) * W + w] = ydiff - hh * k7 - bspl
            B[(RC + 3 * NY + i) * W + w] = hh * (
                _D1 * f0
                + _D3 * B[(K3 + i) * W + w]
                + _D4 * B[(K4 + i) * W + w]
                + _D5 * B[(K5 + i) * W + w]
                + _D6 * B[(K6 + i) * W + w]
                + _D7 * k7
            )


@inl
def records(B, r, t_rec, n_rec, limit, tol, ph, out_Y, out_ph, P):
    """The single run's _record for every accepted lane (row ACT) with a record in its step:
    the records ``< limit`` of its step ``[T, T1]``, the step's end state where a record falls
    on it, else the dense output. The lane's start state, coefficients and end state are first
    gathered into the contiguous rows of ``P`` (6 x NY), so that each record is the single
    run's loop over the states (vectorised over them), not a strided one."""
    for w in range(W):
        if B[ACT * W + w] == 0.0 or not (r[w] < n_rec[w] and t_rec[w, r[w]] < limit[w]):
            continue
        for i in range(NY):
            P[0, i] = B[(Y + i) * W + w]
            P[1, i] = B[(RC + i) * W + w]
            P[2, i] = B[(RC + NY + i) * W + w]
            P[3, i] = B[(RC + 2 * NY + i) * W + w]
            P[4, i] = B[(RC + 3 * NY + i) * W + w]
            P[5, i] = B[(YN + i) * W + w]
        o = out_Y[w]  # the member's own block
        t = B[T * W + w]
        t1 = B[T1 * W + w]
        hh = B[HH * W + w]
        tl = tol[w]
        lim = limit[w]
        p = ph[w]
        rw = r[w]
        while rw < n_rec[w] and t_rec[w, rw] < lim:
            tr = t_rec[w, rw]
            if abs(tr - t1) <= tl:
                for i in range(NY):
                    o[rw, i] = P[5, i]
            else:
                s = (tr - t) / hh
                s1 = 1.0 - s
                for i in range(NY):
                    o[rw, i] = P[0, i] + s * (
                        P[1, i] + s1 * (P[2, i] + s * (P[3, i] + s1 * P[4, i]))
                    )
            out_ph[w, rw] = p
            rw += 1
        r[w] = rw


@inl
def enter(B, w, brk, nph, fkind, fcon, t_rec, n_rec, out_Y, out_ph, ph, r, a, b, tol, start):
    """Lane w (state in rows Y) enters interval ph[w]: the records at its start, its ends,
    tolerance and failure rows, and a fresh step-size guess due (``start``); intervals of zero
    length are passed (as the single run's _solve does). Returns False when the lane's run is
    over (its last interval done: the records at the end taken)."""
    while True:
        p = ph[w]
        if p == nph[w]:  # the end of the run
            t_end = brk[w, p]
            r[w] = records_at(
                B, w, t_end + 1e-9 * max(1.0, abs(t_end)), p - 1, t_rec, n_rec, r[w], out_Y, out_ph
            )
            return False
        a[w] = brk[w, p]
        b[w] = brk[w, p + 1]
        r[w] = records_at(
            B, w, a[w] + 1e-9 * max(1.0, abs(b[w])), p, t_rec, n_rec, r[w], out_Y, out_ph
        )
        if not (b[w] > a[w]):
            ph[w] = p + 1
            continue
        tol[w] = 1e-9 * max(1.0, abs(b[w]))
        for j in range(fkind.shape[2]):
            B[(FK + j) * W + w] = fkind[w, p, j]
            for k in range(5):
                B[(FC + 5 * j + k) * W + w] = fcon[w, p, j, k]
        B[T * W + w] = a[w]
        start[w] = True
        return True


@inl
def begin(B, w, y0, brk, nph, fkind, fcon, h_max, t_rec, n_rec, bound, out_Y, out_ph, status,
          t_stop, bad_out, stats, ph, r, nstep, a, b, tol, start, reject, active):  # fmt: skip
    """Lane w takes its (new) member: its state, counts and first interval (the single run's
    start). Returns False when the member's run is over at once (a bad initial state, or no
    interval of positive length)."""
    B[REFT * W + w] = np.nan  # no reference time yet (strict IEEE: nan != t)
    B[ACT * W + w] = 0.0
    B[HH * W + w] = 0.0
    for i in range(NY):
        B[(Y + i) * W + w] = y0[w, i]
    for k in range(5):
        stats[w, k] = 0
    if not (h_max[w] > 0.0):
        h_max[w] = math.inf
    status[w] = 0
    ph[w] = 0
    r[w] = 0
    nstep[w] = 0
    bad_out[w] = -1
    start[w] = False
    reject[w] = False
    active[w] = False
    B[T * W + w] = brk[w, 0]
    bad = first_bad(B, Y, w, bound)
    if bad >= 0:  # the initial state itself is bad
        keep_stop(B, Y, w, 0, out_Y)
        status[w] = 1
        t_stop[w] = brk[w, 0]
        bad_out[w] = bad
        return False
    if enter(B, w, brk, nph, fkind, fcon, t_rec, n_rec, out_Y, out_ph, ph, r, a, b, tol, start):
        active[w] = True
        return True
    t_stop[w] = brk[w, nph[w]]
    return False


@hot
def run_group(
    B, y0, brk, nph, fkind, fcon, rtol, h_max, t_rec, n_rec, bound, out_Y, out_ph, status,
    nrec_out, t_stop, bad_out, stats, ph, r, nstep, a, b, tol, h, facold, hs, dnf, limit,
    start, reject, last, inside, active, P, fresh, done, refill, passes,
):  # fmt: skip
    """DOPRI5 of the W lanes in lockstep of step attempts, each on its own steps and breaks.

    B: the lane buffer (its constant rows CR.. and tolerance rows ATOL.. filled by the
    caller); y0[W, NY]; brk[W, :], nph[W]: break times and intervals; fkind[W, nph, M] (-1
    healthy, 0 affine, 1 incipient) and fcon[W, nph, M, 5]: the failure of each actuator per
    interval; rtol[W], h_max[W]: the tolerances; t_rec[W, :], n_rec[W]: record times;
    out_Y: a tuple of W arrays [rows, NY] (each member's own records, and the state where it
    stopped in the row after its last record), out_ph[W, rows]: their phases; status[W] (0
    finished, 1 diverged, 2 step size underflow or too many steps), nrec_out, t_stop,
    bad_out[W]; stats[W, 5] as the single run's. The rest: per-lane scratch, and P[6, NY]
    for the records.

    Refill (the caller's queue): the lanes with ``fresh[w]`` take their member first (rows
    of w filled by the caller: constants, tolerances, y0, breaks, failures, records); every
    other lane goes on from where the last call left it (all its state is in B and the
    per-lane arrays). A lane whose member ends sets ``done[w]``. With ``refill`` the call
    returns 1 after the pass in which a member ended (the caller takes its result and gives
    the lane the next member of the queue, or leaves it idle), else it returns 0 once every
    lane is idle. ``passes[0]`` counts the passes (step attempts of the group): W x passes
    lane slots, of which the members' attempts are the occupancy."""
    ended = False
    for w in range(W):
        if fresh[w]:
            fresh[w] = False
            done[w] = False
            B[RT * W + w] = rtol[w]
            if not begin(B, w, y0, brk, nph, fkind, fcon, h_max, t_rec, n_rec, bound, out_Y,
                         out_ph, status, t_stop, bad_out, stats, ph, r, nstep, a, b, tol, start,
                         reject, active):  # fmt: skip
                done[w] = True
                ended = True
    for w in range(W):
        nrec_out[w] = r[w]
    if ended and refill:
        return 1
    while True:
        # lanes entering an interval: f(a, Y) and the fresh step-size guess (HNW I, II.4)
        restart = False
        for w in range(W):
            if active[w] and start[w]:
                restart = True
        if restart:
            for w in range(W):
                B[TIN * W + w] = B[T * W + w]
            for i in range(NY * W):
                B[YT * W + i] = B[Y * W + i]
            rhs_rows(B)
            for w in range(W):
                if active[w] and start[w]:
                    for i in range(NY):
                        B[(F0 + i) * W + w] = B[(DY + i) * W + w]
                    hs[w], dnf[w] = h_start_guess(B, w, rtol[w], h_max[w], b[w] - a[w])
                    B[TIN * W + w] = B[T * W + w] + hs[w]
            rhs_rows(B)
            for w in range(W):
                if active[w] and start[w]:
                    h[w] = h_start_finish(B, w, rtol[w], h_max[w], b[w] - a[w], hs[w], dnf[w], 5.0)
                    stats[w, 2] += 2
                    reject[w] = False
                    facold[w] = 1e-4
                    start[w] = False
        # each active lane's step: its end, size and records (the single run's _steps)
        n_active = 0
        for w in range(W):
            B[ACT * W + w] = 0.0
            B[HH * W + w] = 0.0
            if not active[w]:
                B[T1 * W + w] = B[T * W + w]
                continue
            t = B[T * W + w]
            if nstep[w] >= MAX_STEPS or h[w] < 10.0 * _UROUND * max(1.0, abs(t)):
                keep_stop(B, Y, w, r[w], out_Y)
                status[w] = 2
                t_stop[w] = t
                active[w] = False
                done[w] = True
                ended = True
                B[T1 * W + w] = t
                continue
            last[w] = t + 1.01 * h[w] >= b[w]
            t1 = b[w] if last[w] else t + h[w]
            B[T1 * W + w] = t1
            B[HH * W + w] = t1 - t
            nstep[w] += 1
            last_phase = ph[w] == nph[w] - 1
            limit[w] = t1 + tol[w] if (last[w] and last_phase) else t1 - tol[w]
            inside[w] = r[w] < n_rec[w] and t_rec[w, r[w]] < limit[w]
            n_active += 1
        if n_active == 0:
            break
        passes[0] += 1
        dopri5_stages(B)
        need_dense = False
        for w in range(W):
            if active[w] and inside[w]:
                need_dense = True
        if need_dense:
            dense(B)
        # acceptance per lane: a rejected lane retries, an accepted one records and advances
        n_inside = 0
        for w in range(W):
            if not active[w]:
                continue
            stats[w, 2] += 6
            err = B[ERR * W + w]
            hh = B[HH * W + w]
            if not (err <= 1.0):
                stats[w, 1] += 1
                if err < math.inf:
                    h[w] = hh / min(5.0, err**0.17 / 0.9)
                else:
                    h[w] = 0.1 * hh
                reject[w] = True
                continue
            bad = first_bad(B, YN, w, bound)
            if bad >= 0:
                keep_stop(B, YN, w, r[w], out_Y)
                status[w] = 1
                t_stop[w] = B[T1 * W + w]
                bad_out[w] = bad
                active[w] = False
                done[w] = True
                ended = True
                continue
            stats[w, 0] += 1
            fac11 = err**0.17
            fac = fac11 / facold[w] ** 0.04
            fac = max(0.1, min(5.0, fac / 0.9))
            hnew = hh / fac
            if reject[w]:
                hnew = min(hnew, hh)
            facold[w] = max(err, 1e-4)
            if inside[w]:
                n_inside += 1
            B[ACT * W + w] = 1.0
            h[w] = min(hnew, h_max[w])
            reject[w] = False
        if n_inside > 0:  # the records of the accepted steps, from their start (T, Y)
            records(B, r, t_rec, n_rec, limit, tol, ph, out_Y, out_ph, P)
        # the accepted lanes take their new time, state and f (first same as last)
        for w in range(W):
            if B[ACT * W + w] != 0.0:
                B[T * W + w] = B[T1 * W + w]
        for i in range(NY):
            for w in range(W):
                if B[ACT * W + w] != 0.0:
                    B[(Y + i) * W + w] = B[(YN + i) * W + w]
                    B[(F0 + i) * W + w] = B[(K7 + i) * W + w]
        # lanes whose step reached their interval's end: the next interval, or done
        for w in range(W):
            if B[ACT * W + w] == 0.0 or not last[w]:
                continue
            ph[w] += 1
            if not enter(B, w, brk, nph, fkind, fcon, t_rec, n_rec, out_Y, out_ph, ph, r, a, b,
                         tol, start):  # fmt: skip
                t_stop[w] = brk[w, nph[w]]
                active[w] = False
                done[w] = True
                ended = True
        if ended and refill:  # a member ended: the caller refills its lane
            for w in range(W):
                nrec_out[w] = r[w]
            return 1
    for w in range(W):
        nrec_out[w] = r[w]
    return 0
