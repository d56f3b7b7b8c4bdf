"""Recorded signals of a closed loop, recomputed at the recorded states (template).

The placeholders above the marker exist only so this file imports and lints on its own.
"""

# ruff: noqa: F811
import numpy as np
from numba import njit as jit


def rhs(t, Y, ph, D, W, dY):  # placeholders: every generated module defines its own
    raise NotImplementedError


def plant_dynamics(t, x, uf, p, xdot):
    raise NotImplementedError


def dfailure(k, t, x, u, D):
    raise NotImplementedError


# --- template: begin ---
@jit
def signals(T, Ys, phases, D, W, out):
    """One row of ``out`` per recorded time. Columns: y(p), yd(p), yd_dot(p), e(p), edot(p),
    s(p), sdot(p), q(p), u0(p), u(m), uf(m), uf_comp, gain (N(tau) or rho), control_gain
    (sum_j g_j R_0j df_j/du, the true control gain of output 1 along the allocation),
    sdot_used."""
    nx = W.xdot.size
    p = D.lam.size
    m = D.R.shape[1]
    dY = np.zeros(Ys.shape[1])
    zero = np.zeros(m)
    unit = np.zeros(m)
    x0dot = np.zeros(nx)
    x1dot = np.zeros(nx)
    v0 = D.vel[0]
    for n in range(T.size):
        t = T[n]
        Y = Ys[n]
        ph = phases[n]
        W.misc[3] = 0.0  # the reference cache must not carry over between rows
        rhs(t, Y, ph, D, W, dY)
        sig = W.sig
        ref = W.ref
        for i in range(p):
            out[n, i] = Y[D.pos[i]]
            out[n, p + i] = ref[3 * i]
            out[n, 2 * p + i] = ref[3 * i + 1]
            out[n, 3 * p + i] = sig[nx + i]
            out[n, 4 * p + i] = sig[nx + p + i]
            out[n, 5 * p + i] = sig[nx + 2 * p + i]
            out[n, 6 * p + i] = ref[3 * i + 2] - W.xdot[D.vel[i]] + D.lam[i] * sig[nx + p + i]
            out[n, 7 * p + i] = W.q[i]
            out[n, 8 * p + i] = W.u0[i]
        c = 9 * p
        for j in range(m):
            out[n, c + j] = W.u[j]
            out[n, c + m + j] = W.uf[j]
        c += 2 * m
        out[n, c] = W.misc[0]
        out[n, c + 1] = W.misc[1]
        x = Y[:nx]
        plant_dynamics(t, x, zero, D.plant, x0dot)
        gain = 0.0
        for j in range(m):
            unit[:] = 0.0
            unit[j] = 1.0
            plant_dynamics(t, x, unit, D.plant, x1dot)
            gj = x1dot[v0] - x0dot[v0]
            k = D.fphase[ph, j]
            df = 1.0 if k < 0 else dfailure(k, t, x, W.u[j], D)
            gain += gj * D.R[0, j] * df
        out[n, c + 2] = gain
        out[n, c + 3] = W.misc[2]
