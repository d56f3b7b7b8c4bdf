"""Recorded signals of a closed loop, recomputed at the recorded states (template).

The text after the marker is pasted into the module of integrators that every loop shares
(``compose.integrators``): one compiled ``signals`` serves every loop. It reads the loop's
layout (outputs, places in the work array ``W`` and in ``D.c``) from the table at
``D.i[I_SIGT]`` (``sim/layout.py``), calls the loop's ``rhs`` by address for each row and its
plant's ``control_gain`` (the plant's equations and the failures' slopes, compiled once per
plant in a module of its own, whatever the design) by its address (the shims of
``compose._INTEGRATORS_HEAD``). The placeholders above the marker exist only so this file
imports and lints on its own.
"""

# ruff: noqa: F811
from numba import njit as hot


def rhs(t, Y, ph, D, W, dY):  # placeholders: the integrators module defines them
    raise NotImplementedError


def filtered_error(e, edot, lam):
    raise NotImplementedError


def control_gain(t, Y, ph, D, W, unit, x0dot, x1dot):  # the loop's, by the address in D.i
    raise NotImplementedError


def leaves_envelope(Y, D):  # first plant state outside the plant's envelope, else -1
    raise NotImplementedError


# places in the header of D.i, in the signal table and in misc (the integrators module
# defines them from sim/layout.py: Header, SignalTable, Misc)
I_NX = I_M = I_SIGT = 0
SIGT_P = SIGT_SIG = SIGT_REF = SIGT_XDOT = SIGT_Q = SIGT_U0 = SIGT_U = SIGT_UF = SIGT_MISC = 0
SIGT_LAM = SIGT_POS = 0
MISC_UF_COMP = MISC_GAIN = MISC_SDOT_USED = MISC_REF_VALID = 0


# --- template: begin ---
@hot
def signals(T, Ys, phases, D, W, out, dY, unit, x0dot, x1dot, lean):
    """One row of ``out`` per recorded time. Columns: y(p), yd(p), yd_dot(p), e(p), edot(p),
    s(p), sdot(p), q(p), u0(p), u(m), uf(m), uf_comp, gain (N(tau) or rho), control_gain
    (sum_j g_j R_0j df_j/du, the true control gain of output 1 along the allocation),
    sdot_used.

    ``lean`` (1): ``out`` is the narrow block of the signals a run's metrics, recovery and
    activity read, e(p), u(m), uf(m) (``result.lean_signal_block``), and nothing else is
    computed: not the plant's control gain, and ``rhs`` stops once the commands are known (the
    caller passes a ``dY`` one longer than ``Y``; the generated ``rhs`` then returns before the
    plant's equations, ``parts/skeleton.py``).

    Returns the first row whose plant states leave the plant's envelope (-1: none), so that
    the engine needs no pass of its own over the records to cut a run there.

    ``dY`` (``Ys.shape[1]``, one more when ``lean``), ``unit`` (``M``), ``x0dot``, ``x1dot``
    (``NX``): zeros given by the caller. The rows allocate nothing, so they run without
    reference counting. The table at ``D.i[I_SIGT]``: ``layout.SignalTable`` (written by
    ``LoopLayout.signal_table``); the columns: ``layout.RecordLayout``."""
    c = D.c
    s = D.i[I_SIGT]
    P = D.i[s + SIGT_P]
    SIG, REF, XDOT, Q = D.i[s + SIGT_SIG], D.i[s + SIGT_REF], D.i[s + SIGT_XDOT], D.i[s + SIGT_Q]
    U0, U, UF, MISC = D.i[s + SIGT_U0], D.i[s + SIGT_U], D.i[s + SIGT_UF], D.i[s + SIGT_MISC]
    LAM = D.i[s + SIGT_LAM]
    pos = s + SIGT_POS
    vel = pos + P
    NX = D.i[I_NX]
    M = D.i[I_M]
    outside = -1
    for n in range(T.size):
        t = T[n]
        Y = Ys[n]
        ph = phases[n]
        W[MISC + MISC_REF_VALID] = 0.0  # the reference cache must not carry over between rows
        rhs(t, Y, ph, D, W, dY)
        if lean:  # the narrow block: e(p), u(m), uf(m)
            for i in range(P):
                out[n, i] = W[REF + 3 * i] - Y[D.i[pos + i]]
            for j in range(M):
                out[n, P + j] = W[U + j]
                out[n, P + M + j] = W[UF + j]
            if outside < 0 and leaves_envelope(Y, D) >= 0:
                outside = n
            continue
        for i in range(P):
            pi = D.i[pos + i]
            vi = D.i[vel + i]
            # the true tracking errors (the controller's own, in sig, may be measured ones)
            e = W[REF + 3 * i] - Y[pi]
            ed = W[REF + 3 * i + 1] - Y[vi]
            out[n, i] = Y[pi]
            out[n, P + i] = W[REF + 3 * i]
            out[n, 2 * P + i] = W[REF + 3 * i + 1]
            out[n, 3 * P + i] = e
            out[n, 4 * P + i] = ed
            out[n, 5 * P + i] = filtered_error(e, ed, c[LAM + i])
            out[n, 6 * P + i] = W[REF + 3 * i + 2] - W[XDOT + vi] + c[LAM + i] * W[SIG + NX + P + i]
            out[n, 7 * P + i] = W[Q + i]
            out[n, 8 * P + i] = W[U0 + i]
        col = 9 * P
        for j in range(M):
            out[n, col + j] = W[U + j]
            out[n, col + M + j] = W[UF + j]
        col += 2 * M
        out[n, col] = W[MISC + MISC_UF_COMP]
        out[n, col + 1] = W[MISC + MISC_GAIN]
        out[n, col + 2] = control_gain(t, Y, ph, D, W, unit, x0dot, x1dot)
        out[n, col + 3] = W[MISC + MISC_SDOT_USED]
        if outside < 0 and leaves_envelope(Y, D) >= 0:
            outside = n
    return outside
