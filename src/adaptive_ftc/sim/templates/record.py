"""Recorded signals of a closed loop, recomputed at the recorded states (template).

The placeholders above the marker exist only so this file imports and lints on its own.
"""

# ruff: noqa: F811
from numba import njit as hot


def rhs(t, Y, ph, D, W, dY):  # placeholders: every generated module defines its own
    raise NotImplementedError


def plant_dynamics(t, x, uf, p, xdot):
    raise NotImplementedError


def dfailure(k, t, x, u, D):
    raise NotImplementedError


def filtered_error(e, edot, lam):
    raise NotImplementedError


def plant_params(D):
    raise NotImplementedError


def instance(ph, j, D):
    raise NotImplementedError


# module constants of every generated loop (sizes and places in the work array)
NX = P = M = SIG = N_SIG = REF = N_REF = XDOT = N_XDOT = Q = N_Q = U0 = N_U0 = U = N_U = 0
UF = N_UF = MISC = N_MISC = LAM = RMAT = 0
POS = VEL = (0,)


# --- template: begin ---
@hot
def signals(T, Ys, phases, D, W, out, dY, unit, x0dot, x1dot):
    """One row of ``out`` per recorded time. Columns: y(p), yd(p), yd_dot(p), e(p), edot(p),
    s(p), sdot(p), q(p), u0(p), u(m), uf(m), uf_comp, gain (N(tau) or rho), control_gain
    (sum_j g_j R_0j df_j/du, the true control gain of output 1 along the allocation),
    sdot_used.

    ``dY`` (``Ys.shape[1]``), ``unit`` (``M``), ``x0dot``, ``x1dot`` (``NX``): zeros given by
    the caller. The rows allocate nothing, so they run without reference counting
    (no reference-count operations on the views of every row), and ``signals`` is its own
    entry point (no wrapper for numba to optimise and generate again with the right-hand side
    inside)."""
    c = D.c
    v0 = VEL[0]
    sig = W[SIG : SIG + N_SIG]
    ref = W[REF : REF + N_REF]
    xdot = W[XDOT : XDOT + N_XDOT]
    q = W[Q : Q + N_Q]
    u0 = W[U0 : U0 + N_U0]
    u = W[U : U + N_U]
    uf = W[UF : UF + N_UF]
    misc = W[MISC : MISC + N_MISC]
    for n in range(T.size):
        t = T[n]
        Y = Ys[n]
        ph = phases[n]
        misc[3] = 0.0  # the reference cache must not carry over between rows
        rhs(t, Y, ph, D, W, dY)
        for i in range(P):
            # the true tracking errors (the controller's own, in sig, may be measured ones)
            e = ref[3 * i] - Y[POS[i]]
            ed = ref[3 * i + 1] - Y[VEL[i]]
            out[n, i] = Y[POS[i]]
            out[n, P + i] = ref[3 * i]
            out[n, 2 * P + i] = ref[3 * i + 1]
            out[n, 3 * P + i] = e
            out[n, 4 * P + i] = ed
            out[n, 5 * P + i] = filtered_error(e, ed, c[LAM + i])
            out[n, 6 * P + i] = ref[3 * i + 2] - xdot[VEL[i]] + c[LAM + i] * sig[NX + P + i]
            out[n, 7 * P + i] = q[i]
            out[n, 8 * P + i] = u0[i]
        col = 9 * P
        for j in range(M):
            out[n, col + j] = u[j]
            out[n, col + M + j] = uf[j]
        col += 2 * M
        out[n, col] = misc[0]
        out[n, col + 1] = misc[1]
        x = Y[:NX]
        gain = 0.0
        # j = -1: the plant's rate at zero command (x0dot); then with each unit command. One
        # call site: numba pastes the plant's equations into signals once, not twice
        for j in range(-1, M):
            for i in range(M):
                unit[i] = 0.0
            if j >= 0:
                unit[j] = 1.0
            plant_dynamics(t, x, unit, plant_params(D), x0dot if j < 0 else x1dot)
            if j < 0:
                continue
            gj = x1dot[v0] - x0dot[v0]
            k = instance(ph, j, D)
            df = 1.0 if k < 0 else dfailure(k, t, x, u[j], D)
            gain += gj * c[RMAT + j] * df
        out[n, col + 2] = gain
        out[n, col + 3] = misc[2]
