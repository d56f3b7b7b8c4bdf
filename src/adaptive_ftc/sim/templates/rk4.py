"""Fixed-step classical RK4 with exact restarts at every break time (template).

The placeholders above the marker exist only so this file imports and lints on its own.
"""

# ruff: noqa: F811
import math

from numba import njit as hot
from numba import njit as inl


def rhs(t, Y, ph, D, W, dY):  # placeholder: every generated module defines its own
    raise NotImplementedError


def jump(t, Y, ph, D, W):  # placeholder: state update at the start of each interval
    raise NotImplementedError


def leaves_envelope(Y, D):  # placeholder: first plant state outside the plant's envelope
    raise NotImplementedError


# --- template: begin ---
@inl
def first_bad(Y, bound, D):
    """Index of the first state that is non-finite, not below ``bound`` in size or (a plant
    state) outside the plant's envelope; -1 if none."""
    for i in range(Y.size):
        if not (abs(Y[i]) < bound):  # catches nan too
            return i
    return leaves_envelope(Y, D)  # a plant state outside the plant's envelope


@inl
def keep_stop(r, out_Y, Y):
    """Leave the state where a run stopped early in the row after the last record (never read
    as a record; the engine reads it to say why the run stopped)."""
    if r < out_Y.shape[0]:
        for i in range(Y.size):
            out_Y[r, i] = Y[i]


@inl
def record_hermite(out_Y, r, tr, t, h, Y, k1, yn, fe):
    """Cubic Hermite interpolant between ``(t, Y, k1)`` and ``(t + h, yn, fe)`` at ``tr``."""
    s = (tr - t) / h
    s2 = s * s  # products, not s**2 and s**3: the same numbers, without numba's power code
    s3 = s * s2
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    for i in range(Y.size):
        out_Y[r, i] = h00 * Y[i] + h10 * h * k1[i] + h01 * yn[i] + h11 * h * fe[i]


@inl
def rk4_step(t, t1, hh, ph, D, W, Y, k1, k2, k3, k4, yt, yn):
    """One classical RK4 step from ``(t, Y)`` to ``t1 = t + hh``: the stages in ``k1..k4``, the
    new state in ``yn`` (``yt``: the stages' state)."""
    n = Y.size
    rhs(t, Y, ph, D, W, k1)
    for i in range(n):
        yt[i] = Y[i] + 0.5 * hh * k1[i]
    rhs(t + 0.5 * hh, yt, ph, D, W, k2)
    for i in range(n):
        yt[i] = Y[i] + 0.5 * hh * k2[i]
    rhs(t + 0.5 * hh, yt, ph, D, W, k3)
    for i in range(n):
        yt[i] = Y[i] + hh * k3[i]
    rhs(t1, yt, ph, D, W, k4)
    for i in range(n):
        yn[i] = Y[i] + hh / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@inl
def rk4_records(r, t_rec, limit, tol, t, t1, hh, ph, D, W, Y, k1, yn, fe, out_Y, out_phase, stats):
    """Write the records ``t_rec[r] < limit`` of the step ``[t, t1]``: the step's end state where
    a record falls on it, else the cubic Hermite interpolant (``f(t1, yn)`` into ``fe``, once).
    Returns the new ``r``."""
    have_end = False
    while r < t_rec.size and t_rec[r] < limit:
        tr = t_rec[r]
        if abs(tr - t1) <= tol:
            for i in range(Y.size):
                out_Y[r, i] = yn[i]
        else:
            if not have_end:
                rhs(t1, yn, ph, D, W, fe)
                stats[2] += 1
                have_end = True
            record_hermite(out_Y, r, tr, t, hh, Y, k1, yn, fe)
        out_phase[r] = ph
        r += 1
    return r


@hot
def integrate_rk4(
    y0, t_breaks, dt, t_rec, D, W, bound, stop, out_Y, out_phase, stats,
    Y, k1, k2, k3, k4, yt, yn, fe,
):  # fmt: skip
    """Classical RK4 with steps landing exactly on every break time.

    Records the state at the times ``t_rec`` (exactly where a step ends there, else by cubic
    Hermite interpolation). A record at a break time belongs to the phase that starts there.
    ``stop[0] != 0`` (set from another thread) interrupts the run after the current step.
    ``Y, k1, k2, k3, k4, yt, yn, fe`` are scratch arrays of ``y0.size`` given by the caller (the
    state, the four stages, the stage state, the new state, f at a step's end). So the loop
    allocates nothing and runs without reference counting (measured: 40 % faster than under
    numba's reference counting), and it is its own entry point (no wrapper for numba to
    optimise and generate again with the whole loop inside). Separate arrays, not the rows of
    one: rows sliced here made the loop 50 % slower (the compiler then keeps every row's
    values in memory).

    Returns ``(n_recorded, status, t_stop, bad_index)``; status 0 = finished, 1 = diverged,
    3 = interrupted; on status 1 the state where the run stopped is left in
    ``out_Y[n_recorded]`` (when that row exists). ``stats`` receives [steps, rejected, rhs
    evaluations, 0, 0].
    """
    for i in range(y0.size):
        Y[i] = y0[i]
    n = Y.size
    nrec = t_rec.size
    r = 0
    nph = t_breaks.size - 1
    t_end = t_breaks[nph]
    bad = first_bad(Y, bound, D)
    if bad >= 0:
        keep_stop(0, out_Y, Y)
        return 0, 1, t_breaks[0], bad
    for ph in range(nph):
        a = t_breaks[ph]
        b = t_breaks[ph + 1]
        tol = 1e-9 * max(1.0, abs(b))
        nsteps = max(1, int(math.ceil((b - a) / dt - 1e-9)))
        h = (b - a) / nsteps
        jump(a, Y, ph, D, W)  # e.g. a sampled controller's new command (no-op if continuous)
        while r < nrec and t_rec[r] <= a + tol:
            for i in range(n):
                out_Y[r, i] = Y[i]
            out_phase[r] = ph
            r += 1
        for st in range(nsteps):
            if stop[0] != 0:
                return r, 3, a + st * h, -1
            t = a + st * h
            t1 = b if st == nsteps - 1 else a + (st + 1) * h
            hh = t1 - t
            rk4_step(t, t1, hh, ph, D, W, Y, k1, k2, k3, k4, yt, yn)
            stats[0] += 1
            stats[2] += 4
            bad = first_bad(yn, bound, D)
            if bad >= 0:
                keep_stop(r, out_Y, yn)
                return r, 1, t1, bad
            last = ph == nph - 1 and st == nsteps - 1
            limit = t1 + tol if last else t1 - tol
            if r < nrec and t_rec[r] < limit:
                r = rk4_records(r, t_rec, limit, tol, t, t1, hh, ph, D, W, Y, k1, yn, fe, out_Y,
                                out_phase, stats)  # fmt: skip
            for i in range(n):
                Y[i] = yn[i]
    while r < nrec and t_rec[r] <= t_end + 1e-9 * max(1.0, abs(t_end)):
        for i in range(n):
            out_Y[r, i] = Y[i]
        out_phase[r] = nph - 1
        r += 1
    return r, 0, t_end, -1
