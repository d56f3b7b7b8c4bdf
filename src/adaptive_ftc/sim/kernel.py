"""Compiled closed-loop kernel (numba).

Everything that runs millions of times per simulation lives here: the postfix expression
interpreter, the regressors, the four thesis plants, the five adaptive laws, the closed-loop
right-hand side and the fixed-step RK4 loop. A closed loop is handed to the kernel as a plain
tuple of arrays (the "model", built by :mod:`adaptive_ftc.sim.assemble`), so one compiled,
disk-cached kernel serves every scenario without recompiling.

The layout of the model tuple and of its integer/float settings is fixed by the index constants
below; :mod:`adaptive_ftc.sim.assemble` is the only writer.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

# --- model tuple fields --------------------------------------------------------------------
F_INTS, F_FLTS, F_PLANT = 0, 1, 2
F_POS, F_VEL, F_R = 3, 4, 5
F_OPS, F_VALS, F_PSTART = 6, 7, 8
F_REF, F_PHASE, F_DPHASE = 9, 10, 11
F_RKIND, F_RIN, F_RNIN, F_RNMF, F_RC, F_RA, F_RSIZE, F_ROFF = 12, 13, 14, 15, 16, 17, 18, 19
F_LAM, F_K, F_K0 = 20, 21, 22
F_BPROG, F_BN, F_BOFF = 23, 24, 25

# --- integer settings (model[F_INTS]) --------------------------------------------------------
I_PLANT, I_NX, I_M, I_P, I_CTRL, I_NTHETA, I_NY = 0, 1, 2, 3, 4, 5, 6
I_SDOT, I_ADAPT, I_NUSS, I_TAU, I_RHO, I_FILT, I_NSIG, I_NREG = 7, 8, 9, 10, 11, 12, 13, 14
N_INTS = 15
# --- float settings (model[F_FLTS]) ----------------------------------------------------------
X_EPS0, X_GAMMA, X_SIGMA, X_GAMMA2, X_SIGMA2, X_FTAU, X_BOUND = 0, 1, 2, 3, 4, 5, 6
N_FLTS = 7

from adaptive_ftc._codes import (  # noqa: E402, F401  (re-exported for assemble)
    CTRL_DIRECT,
    CTRL_ESTIMATION,
    CTRL_NUSSBAUM,
    CTRL_SIGN,
    PLANT_HYPERSONIC,
    PLANT_MANIPULATOR,
    PLANT_SPACECRAFT,
    PLANT_WINGROCK,
    REG_FUZZY_NORMALISED,
    REG_FUZZY_RAW,
    REG_LINEAR,
    REG_LINEAR_BIAS,
)

# --- work buffers (tuple W) ------------------------------------------------------------------
W_STACK, W_PHI, W_SIG, W_MU, W_U0, W_U, W_UF, W_XDOT, W_REF, W_Q, W_MISC = range(11)
# W_MISC slots
M_UF_COMP, M_GAIN, M_SDOT_USED, M_REF_T, M_REF_VALID = 0, 1, 2, 3, 4

_jit = nb.njit(cache=True, nogil=True, error_model="numpy")
# hot-path functions never allocate, so they run without reference counting
_hot = nb.njit(cache=True, nogil=True, error_model="numpy", _nrt=False)


# ============================================================================ expressions
@_hot
def eval_program(ops, vals, start, end, t, x, u, stack):
    """Run postfix program ``ops[start:end]`` for time ``t``, state ``x`` and input ``u``."""
    sp = 0
    for i in range(start, end):
        op = ops[i]
        if op == 0:
            stack[sp] = vals[i]
            sp += 1
        elif op == 1:
            stack[sp] = t
            sp += 1
        elif op == 2:
            stack[sp] = x[int(vals[i])]
            sp += 1
        elif op == 3:
            stack[sp] = u
            sp += 1
        elif op <= 8:
            b = stack[sp - 1]
            a = stack[sp - 2]
            sp -= 1
            if op == 4:
                r = a + b
            elif op == 5:
                r = a - b
            elif op == 6:
                r = a * b
            elif op == 7:
                r = (
                    a / b
                    if b != 0.0
                    else (math.inf if a > 0 else (-math.inf if a < 0 else math.nan))
                )
            else:
                if b == 2.0:
                    r = a * a
                elif b == 3.0:
                    r = a * a * a
                elif a < 0.0 and b != math.floor(b):
                    r = math.nan
                elif a == 0.0 and b < 0.0:
                    r = math.inf
                else:
                    r = a**b
            stack[sp - 1] = r
        elif op == 9:
            stack[sp - 1] = -stack[sp - 1]
        elif op < 30:
            a = stack[sp - 1]
            if op == 10:
                r = math.sin(a)
            elif op == 11:
                r = math.cos(a)
            elif op == 12:
                r = math.tan(a)
            elif op == 13:
                r = math.exp(a) if a < 700.0 else math.inf
            elif op == 14:
                r = math.log(a) if a > 0.0 else (-math.inf if a == 0.0 else math.nan)
            elif op == 15:
                r = math.sqrt(a) if a >= 0.0 else math.nan
            elif op == 16:
                r = math.tanh(a)
            elif op == 17:
                r = abs(a)
            elif op == 18:
                r = 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)
            elif op == 19:
                r = math.atan(a)
            elif op == 20:
                r = math.asin(a) if abs(a) <= 1.0 else math.nan
            elif op == 21:
                r = math.acos(a) if abs(a) <= 1.0 else math.nan
            elif op == 22:
                r = math.sinh(a) if abs(a) < 700.0 else math.copysign(math.inf, a)
            else:
                r = math.cosh(a) if abs(a) < 700.0 else math.inf
            stack[sp - 1] = r
        elif op == 32 or op == 35:
            hi = stack[sp - 1]
            lo = stack[sp - 2]
            a = stack[sp - 3]
            sp -= 2
            if op == 32:
                stack[sp - 1] = min(max(a, lo), hi)
            else:
                stack[sp - 1] = 1.0 if (a > lo and a < hi) else 0.0
        else:
            b = stack[sp - 1]
            a = stack[sp - 2]
            sp -= 1
            if op == 30:
                r = min(a, b)
            elif op == 31:
                r = max(a, b)
            elif op == 33:
                r = math.atan2(a, b)
            else:
                r = 1.0 if a < b else 0.0
            stack[sp - 1] = r
    return stack[0]


@_hot
def run_program(M, k, t, x, u, stack):
    """Evaluate program number ``k`` of the model."""
    ps = M[F_PSTART]
    return eval_program(M[F_OPS], M[F_VALS], ps[k], ps[k + 1], t, x, u, stack)


# ============================================================================ regressors
@_jit
def regressor(M, r, sig, phi, off, mu):
    """Write regressor ``r``'s vector Pi(z) into ``phi[off:off+size]``; z = sig[inputs]."""
    _regressor(
        M[F_RKIND][r],
        M[F_RNIN][r],
        r,
        M[F_RIN],
        M[F_RNMF],
        M[F_RC],
        M[F_RA],
        M[F_RSIZE][r],
        sig,
        phi,
        off,
        mu,
    )


@_hot
def _regressor(kind, nin, r, idx, nmf, cen, aa, size, sig, phi, off, mu):
    # the model's arrays are indexed in place ([r, i, l]): creating views costs more than the
    # arithmetic here
    if kind == REG_LINEAR_BIAS or kind == REG_LINEAR:
        j = off
        if kind == REG_LINEAR_BIAS:
            phi[j] = 1.0
            j += 1
        for i in range(nin):
            phi[j] = sig[idx[r, i]]
            j += 1
        return
    maxmf = cen.shape[2]
    for i in range(nin):
        z = sig[idx[r, i]]
        for l in range(nmf[r, i]):
            d = z - cen[r, i, l]
            mu[i * maxmf + l] = math.exp(-aa[r, i, l] * d * d)
    total = 0.0
    # odometer over membership indices (last input fastest), no integer division
    cnt = mu[mu.size - nin :]  # the tail of the work buffer holds the rule counters
    for rule in range(size):
        prod = 1.0
        for i in range(nin):
            prod *= mu[i * maxmf + int(cnt[i])]
        phi[off + rule] = prod
        total += prod
        i = nin - 1
        while i >= 0:
            cnt[i] += 1.0
            if cnt[i] < nmf[r, i]:
                break
            cnt[i] = 0.0
            i -= 1
    if kind == REG_FUZZY_NORMALISED:
        if total > 1e-300:
            for rule in range(size):
                phi[off + rule] /= total
        else:
            for rule in range(size):
                phi[off + rule] = 1.0 / size


# ============================================================================ plants
@_hot
def plant_derivative(kind, P, t, x, uf, xdot):
    """Plant state derivative for applied actuator outputs ``uf`` (written into ``xdot``)."""
    if kind == PLANT_HYPERSONIC:
        a = x[0]
        q = x[1]
        usum = 0.0
        for j in range(uf.size):
            usum += uf[j]
        xdot[0] = q
        xdot[1] = P[0] * (
            P[1] * (P[2] * a * a + P[3] * a + P[4])
            + P[5] * q * (P[6] * a * a + P[7] * a + P[8])
            + P[9] * (usum - a)
        )
    elif kind == PLANT_WINGROCK:
        ph = x[0]
        pd = x[1]
        acc = (
            -P[0] * ph - P[1] * pd - P[2] * abs(pd) * pd - P[3] * ph * ph * ph - P[4] * ph * ph * pd
        )
        for j in range(uf.size):
            acc += P[5 + j] * uf[j]
        xdot[0] = pd
        xdot[1] = acc
    elif kind == PLANT_MANIPULATOR:
        a1, a2, a3, a4 = P[0], P[1], P[2], P[3]
        q2 = x[2]
        qd1 = x[1]
        qd2 = x[3]
        c = math.cos(q2)
        s = math.sin(q2)
        m11 = a1 + 2.0 * a3 * c + 2.0 * a4 * s
        m12 = a2 + a3 * c + a4 * s
        m22 = a2
        h = a3 * s - a4 * c
        tau1 = uf[0] + uf[1]
        tau2 = uf[2] + uf[3]
        r1 = tau1 - (-h * qd2 * qd1 - h * (qd1 + qd2) * qd2)
        r2 = tau2 - (h * qd1 * qd1)
        det = m11 * m22 - m12 * m12
        xdot[0] = qd1
        xdot[1] = (m22 * r1 - m12 * r2) / det
        xdot[2] = qd2
        xdot[3] = (-m12 * r1 + m11 * r2) / det
    else:
        _spacecraft(P, t, x, uf, xdot)


@_hot
def _spacecraft(P, t, x, uf, xdot):
    # P: J(3), delta(9 row-major, axes x modes), Lambda(3), xi(3), w0, disturbance flag
    w0 = P[18]
    phi, dphi, _th, dth, psi, dpsi = x[0], x[1], x[2], x[3], x[4], x[5]
    w1 = dphi - w0 * psi
    w2 = dth - w0
    w3 = dpsi + w0 * phi
    # wheel momentum along the body axes: R hw with R = [I3 I3]
    h1 = x[12] + x[15]
    h2 = x[13] + x[16]
    h3 = x[14] + x[17]
    J1, J2, J3 = P[0], P[1], P[2]
    H1 = J1 * w1 + h1
    H2 = J2 * w2 + h2
    H3 = J3 * w3 + h3
    # w x H
    c1 = w2 * H3 - w3 * H2
    c2 = w3 * H1 - w1 * H3
    c3 = w1 * H2 - w2 * H1
    if P[19] != 0.0:
        td1 = 1e-3 * (
            -3.0
            + 3.0 * math.cos(0.01 * t)
            - 4.5 * math.sin(0.02 * t)
            + 3.0 * w1 * math.cos(0.015 * t)
        )
        td2 = 1e-3 * (
            6.0
            + 4.5 * math.sin(0.01 * t)
            - 6.0 * math.cos(0.02 * t)
            - 6.0 * w2 * math.sin(0.015 * t)
        )
        td3 = 1e-3 * (
            -6.0
            + 6.0 * math.sin(0.01 * t)
            + 4.5 * math.cos(0.02 * t)
            - 3.0 * w3 * math.sin(0.015 * t)
        )
    else:
        td1 = 0.0
        td2 = 0.0
        td3 = 0.0
    # modal forcing: eta_dd = -2 xi L eta_d - L^2 eta - delta^T w_dot  =: g - delta^T w_dot
    l1, l2, l3 = P[12], P[13], P[14]
    g1 = -2.0 * P[15] * l1 * x[9] - l1 * l1 * x[6]
    g2 = -2.0 * P[16] * l2 * x[10] - l2 * l2 * x[7]
    g3 = -2.0 * P[17] * l3 * x[11] - l3 * l3 * x[8]
    d11, d12, d13 = P[3], P[4], P[5]
    d21, d22, d23 = P[6], P[7], P[8]
    d31, d32, d33 = P[9], P[10], P[11]
    # (J - delta delta^T) w_dot = R u + T_d - w x H - delta g
    b1 = uf[0] + uf[3] + td1 - c1 - (d11 * g1 + d12 * g2 + d13 * g3)
    b2 = uf[1] + uf[4] + td2 - c2 - (d21 * g1 + d22 * g2 + d23 * g3)
    b3 = uf[2] + uf[5] + td3 - c3 - (d31 * g1 + d32 * g2 + d33 * g3)
    a11 = J1 - (d11 * d11 + d12 * d12 + d13 * d13)
    a22 = J2 - (d21 * d21 + d22 * d22 + d23 * d23)
    a33 = J3 - (d31 * d31 + d32 * d32 + d33 * d33)
    a12 = -(d11 * d21 + d12 * d22 + d13 * d23)
    a13 = -(d11 * d31 + d12 * d32 + d13 * d33)
    a23 = -(d21 * d31 + d22 * d32 + d23 * d33)
    # symmetric 3x3 solve by Cramer's rule
    c11 = a22 * a33 - a23 * a23
    c12 = a13 * a23 - a12 * a33
    c13 = a12 * a23 - a13 * a22
    c22 = a11 * a33 - a13 * a13
    c23 = a12 * a13 - a11 * a23
    c33 = a11 * a22 - a12 * a12
    det = a11 * c11 + a12 * c12 + a13 * c13
    wd1 = (c11 * b1 + c12 * b2 + c13 * b3) / det
    wd2 = (c12 * b1 + c22 * b2 + c23 * b3) / det
    wd3 = (c13 * b1 + c23 * b2 + c33 * b3) / det
    xdot[0] = dphi
    xdot[1] = wd1 + w0 * dpsi
    xdot[2] = dth
    xdot[3] = wd2
    xdot[4] = dpsi
    xdot[5] = wd3 - w0 * dphi
    xdot[6] = x[9]
    xdot[7] = x[10]
    xdot[8] = x[11]
    xdot[9] = g1 - (d11 * wd1 + d21 * wd2 + d31 * wd3)
    xdot[10] = g2 - (d12 * wd1 + d22 * wd2 + d32 * wd3)
    xdot[11] = g3 - (d13 * wd1 + d23 * wd2 + d33 * wd3)
    for j in range(6):
        xdot[12 + j] = -uf[j]


# ============================================================================ closed loop
@_hot
def closed_loop(t, Y, phase, M, W, dY):
    """Closed-loop derivative ``dY`` of plant + adaptive states ``Y`` (in place).

    Leaves the intermediate signals (regressor, u0, commands, applied outputs, plant
    derivative, reference, q = sdot + k s + k0 tanh(s/eps0)) in the work buffers ``W``.
    """
    ints = M[F_INTS]
    flts = M[F_FLTS]
    nx = ints[I_NX]
    m = ints[I_M]
    p = ints[I_P]
    ctrl = ints[I_CTRL]
    ntheta = ints[I_NTHETA]
    stack = W[W_STACK]
    phi = W[W_PHI]
    sig = W[W_SIG]
    u0 = W[W_U0]
    u = W[W_U]
    uf = W[W_UF]
    xdot = W[W_XDOT]
    ref = W[W_REF]
    q = W[W_Q]
    misc = W[W_MISC]
    x = Y[:nx]
    th = Y[nx : nx + ntheta]
    pos = M[F_POS]
    vel = M[F_VEL]
    lam = M[F_LAM]
    # reference and errors; signal vector = [x, e, edot, s]
    for i in range(nx):
        sig[i] = x[i]
    refp = M[F_REF]
    ops = M[F_OPS]
    vals = M[F_VALS]
    ps = M[F_PSTART]
    if not (misc[M_REF_VALID] == 1.0 and misc[M_REF_T] == t):
        for i in range(p):
            for d in range(3):
                k_ = refp[i, d]
                ref[3 * i + d] = eval_program(ops, vals, ps[k_], ps[k_ + 1], t, x, 0.0, stack)
        misc[M_REF_T] = t
        misc[M_REF_VALID] = 1.0
    for i in range(p):
        e = ref[3 * i] - x[pos[i]]
        ed = ref[3 * i + 1] - x[vel[i]]
        sig[nx + i] = e
        sig[nx + p + i] = ed
        sig[nx + 2 * p + i] = ed + lam[i] * e
    # control u0_i = Pi_i^T theta_i
    nreg = ints[I_NREG]
    rsize = M[F_RSIZE]
    roff = M[F_ROFF]
    mu = W[W_MU]
    for r in range(nreg):
        off = roff[r]
        _regressor(
            M[F_RKIND][r],
            M[F_RNIN][r],
            r,
            M[F_RIN],
            M[F_RNMF],
            M[F_RC],
            M[F_RA],
            rsize[r],
            sig,
            phi,
            off,
            mu,
        )
        acc = 0.0
        for l in range(rsize[r]):
            acc += phi[off + l] * th[off + l]
        u0[r] = acc
    misc[M_UF_COMP] = 0.0
    if ctrl == CTRL_ESTIMATION:
        bn = M[F_BN]
        bprog = M[F_BPROG]
        boff = M[F_BOFF]
        comp = 0.0
        for j in range(m):
            for l in range(bn[j]):
                k_ = bprog[j, l]
                comp -= Y[boff[j] + l] * eval_program(
                    ops, vals, ps[k_], ps[k_ + 1], t, x, 0.0, stack
                )
        misc[M_UF_COMP] = comp
        u0[0] += comp
    # allocation u = R^T u0 and actuator failures
    R = M[F_R]
    pp = M[F_PHASE]
    for j in range(m):
        acc = 0.0
        for i in range(p):
            acc += R[i, j] * u0[i]
        u[j] = acc
        if pp[phase, j] < 0:
            uf[j] = acc
        else:
            k_ = pp[phase, j]
            uf[j] = eval_program(ops, vals, ps[k_], ps[k_ + 1], t, x, acc, stack)
    plant_derivative(ints[I_PLANT], M[F_PLANT], t, x, uf, xdot)
    for i in range(nx):
        dY[i] = xdot[i]
    # exact sdot from the plant derivative, or a dirty-derivative filter of s
    k = M[F_K]
    k0 = M[F_K0]
    eps0 = flts[X_EPS0]
    filt = ints[I_FILT]
    for i in range(p):
        s = sig[nx + 2 * p + i]
        if ints[I_SDOT] == 0:
            sd = ref[3 * i + 2] - xdot[vel[i]] + lam[i] * sig[nx + p + i]
        else:
            sd = (s - Y[filt + i]) / flts[X_FTAU]
            dY[filt + i] = sd
        q[i] = sd + k[i] * s + k0[i] * math.tanh(s / eps0)
        if i == 0:
            misc[M_SDOT_USED] = sd
    # adaptive laws
    gamma = flts[X_GAMMA]
    sigma = flts[X_SIGMA]
    adapt = ints[I_ADAPT] != 0
    ny = ints[I_NY]
    if not adapt:
        for i in range(nx, ny):
            if ints[I_SDOT] == 0 or i < filt or i >= filt + p:
                dY[i] = 0.0
        return
    if ctrl == CTRL_NUSSBAUM:
        tau = Y[ints[I_TAU]]
        k_ = ints[I_NUSS]
        gain = eval_program(ops, vals, ps[k_], ps[k_ + 1], tau, x, 0.0, stack)
        misc[M_GAIN] = gain
        dY[ints[I_TAU]] = flts[X_GAMMA2] * q[0] * q[0]
    elif ctrl == CTRL_SIGN:
        rho = Y[ints[I_RHO]]
        gain = rho
        misc[M_GAIN] = rho
        dY[ints[I_RHO]] = -flts[X_GAMMA2] * u0[0] * q[0] - flts[X_GAMMA2] * flts[X_SIGMA2] * rho
    else:
        gain = 1.0
        misc[M_GAIN] = 1.0
    for r in range(nreg):
        off = roff[r]
        for l in range(rsize[r]):
            dY[nx + off + l] = gamma * gain * phi[off + l] * q[r] - gamma * sigma * th[off + l]
    if ctrl == CTRL_ESTIMATION:
        g2 = flts[X_GAMMA2]
        s2 = flts[X_SIGMA2]
        bn = M[F_BN]
        bprog = M[F_BPROG]
        boff = M[F_BOFF]
        for j in range(m):
            for l in range(bn[j]):
                k_ = bprog[j, l]
                w = eval_program(ops, vals, ps[k_], ps[k_ + 1], t, x, 0.0, stack)
                dY[boff[j] + l] = -g2 * w * q[0] - g2 * s2 * Y[boff[j] + l]


@_jit
def make_work(M):
    """Allocate the work buffers for model ``M``."""
    ints = M[F_INTS]
    nx, m, p = ints[I_NX], ints[I_M], ints[I_P]
    maxin = M[F_RC].shape[1]
    maxmf = M[F_RC].shape[2]
    return (
        np.zeros(64),
        np.zeros(max(ints[I_NTHETA], 1)),
        np.zeros(ints[I_NSIG]),
        np.zeros(maxin * maxmf + maxin + 1),
        np.zeros(p),
        np.zeros(m),
        np.zeros(m),
        np.zeros(nx),
        np.zeros(3 * p),
        np.zeros(p),
        np.zeros(8),
    )


@_jit
def derivative(t, Y, phase, M):
    """Allocating closed-loop derivative (used by the variable-step scipy path)."""
    W = make_work(M)
    dY = np.zeros(Y.size)
    closed_loop(t, Y, phase, M, W, dY)
    return dY


@_jit
def plant_derivative_alloc(kind, P, nx, t, x, uf):
    """Allocating plant derivative (Python-facing convenience)."""
    xdot = np.zeros(nx)
    plant_derivative(kind, P, t, x, uf, xdot)
    return xdot


@_jit
def regressor_alloc(M, r, sig):
    """Allocating regressor evaluation (Python-facing convenience)."""
    W = make_work(M)
    phi = np.zeros(M[F_RSIZE][r])
    regressor(M, r, sig, phi, 0, W[W_MU])
    return phi


# ============================================================================ integration
@_jit
def _check(Y, bound):
    for i in range(Y.size):
        v = Y[i]
        if not (abs(v) < bound):  # catches nan too
            return i
    return -1


@_jit
def integrate_rk4(M, y0, t_breaks, dt, t_rec, out_Y, out_phase):
    """Classical RK4 with steps landing exactly on every break time.

    Records the state at the times ``t_rec`` (exactly where a step ends there, else by cubic
    Hermite interpolation). A record at a break time belongs to the phase that starts there.

    Returns ``(n_recorded, status, t_stop, bad_index)``; status 0 = finished, 1 = diverged.
    """
    n = y0.size
    W = make_work(M)
    Y = y0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    yt = np.empty(n)
    yn = np.empty(n)
    fe = np.empty(n)
    bound = M[F_FLTS][X_BOUND]
    nrec = t_rec.size
    r = 0
    nph = t_breaks.size - 1
    t_end = t_breaks[nph]
    bad = _check(Y, bound)
    if bad >= 0:
        return 0, 1, t_breaks[0], bad
    for ph in range(nph):
        a = t_breaks[ph]
        b = t_breaks[ph + 1]
        tol = 1e-9 * max(1.0, abs(b))
        nsteps = max(1, int(math.ceil((b - a) / dt - 1e-9)))
        h = (b - a) / nsteps
        while r < nrec and t_rec[r] <= a + tol:
            out_Y[r, :] = Y
            out_phase[r] = ph
            r += 1
        for st in range(nsteps):
            t = a + st * h
            t1 = b if st == nsteps - 1 else a + (st + 1) * h
            hh = t1 - t
            closed_loop(t, Y, ph, M, W, k1)
            for i in range(n):
                yt[i] = Y[i] + 0.5 * hh * k1[i]
            closed_loop(t + 0.5 * hh, yt, ph, M, W, k2)
            for i in range(n):
                yt[i] = Y[i] + 0.5 * hh * k2[i]
            closed_loop(t + 0.5 * hh, yt, ph, M, W, k3)
            for i in range(n):
                yt[i] = Y[i] + hh * k3[i]
            closed_loop(t1, yt, ph, M, W, k4)
            for i in range(n):
                yn[i] = Y[i] + hh / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            bad = _check(yn, bound)
            if bad >= 0:
                return r, 1, t1, bad
            last = ph == nph - 1 and st == nsteps - 1
            limit = t1 + tol if last else t1 - tol
            if r < nrec and t_rec[r] < limit:
                have_end = False
                while r < nrec and t_rec[r] < limit:
                    tr = t_rec[r]
                    if abs(tr - t1) <= tol:
                        out_Y[r, :] = yn
                    else:
                        if not have_end:
                            closed_loop(t1, yn, ph, M, W, fe)
                            have_end = True
                        # cubic Hermite between (t, Y, k1) and (t1, yn, fe)
                        sft = (tr - t) / hh
                        h00 = 2 * sft**3 - 3 * sft**2 + 1
                        h10 = sft**3 - 2 * sft**2 + sft
                        h01 = -2 * sft**3 + 3 * sft**2
                        h11 = sft**3 - sft**2
                        for i in range(n):
                            out_Y[r, i] = (
                                h00 * Y[i] + h10 * hh * k1[i] + h01 * yn[i] + h11 * hh * fe[i]
                            )
                    out_phase[r] = ph
                    r += 1
            Y[:] = yn
    while r < nrec and t_rec[r] <= t_end + 1e-9 * max(1.0, abs(t_end)):
        out_Y[r, :] = Y
        out_phase[r] = nph - 1
        r += 1
    return r, 0, t_end, -1


# ============================================================================ recorded signals
@_jit
def signals(M, T, Ys, phases, out):
    """Recompute the closed-loop signals at recorded points (one row of ``out`` per time).

    Columns: y(p), yd(p), yd_dot(p), e(p), edot(p), s(p), sdot(p), q(p), u0(p), u(m), uf(m),
    uf_comp, gain (N(tau) or rho), control_gain (sum_j g_j R_0j df_j/du), sdot_used.
    """
    ints = M[F_INTS]
    nx, m, p = ints[I_NX], ints[I_M], ints[I_P]
    W = make_work(M)
    dY = np.zeros(Ys.shape[1])
    pos = M[F_POS]
    vel = M[F_VEL]
    stack = W[W_STACK]
    zero = np.zeros(m)
    unit = np.zeros(m)
    x0dot = np.zeros(nx)
    x1dot = np.zeros(nx)
    R = M[F_R]
    lam = M[F_LAM]
    for n in range(T.size):
        t = T[n]
        Y = Ys[n]
        ph = phases[n]
        closed_loop(t, Y, ph, M, W, dY)
        sig = W[W_SIG]
        ref = W[W_REF]
        xdot = W[W_XDOT]
        c = 0
        for i in range(p):
            out[n, c + i] = Y[pos[i]]
            out[n, c + p + i] = ref[3 * i]
            out[n, c + 2 * p + i] = ref[3 * i + 1]
            out[n, c + 3 * p + i] = sig[nx + i]
            out[n, c + 4 * p + i] = sig[nx + p + i]
            out[n, c + 5 * p + i] = sig[nx + 2 * p + i]
            out[n, c + 6 * p + i] = ref[3 * i + 2] - xdot[vel[i]] + lam[i] * sig[nx + p + i]
            out[n, c + 7 * p + i] = W[W_Q][i]
            out[n, c + 8 * p + i] = W[W_U0][i]
        c = 9 * p
        for j in range(m):
            out[n, c + j] = W[W_U][j]
            out[n, c + m + j] = W[W_UF][j]
        c += 2 * m
        out[n, c] = W[W_MISC][M_UF_COMP]
        out[n, c + 1] = W[W_MISC][M_GAIN]
        # true control gain of output 0 along the allocation: sum_j g_j R_0j df_j/du_j
        plant_derivative(ints[I_PLANT], M[F_PLANT], t, Y[:nx], zero, x0dot)
        dph = M[F_DPHASE][ph]
        gain = 0.0
        for j in range(m):
            unit[:] = 0.0
            unit[j] = 1.0
            plant_derivative(ints[I_PLANT], M[F_PLANT], t, Y[:nx], unit, x1dot)
            gj = x1dot[vel[0]] - x0dot[vel[0]]
            if dph[j] < 0:
                df = 1.0
            else:
                df = run_program(M, dph[j], t, Y[:nx], W[W_U][j], stack)
            gain += gj * R[0, j] * df
        out[n, c + 2] = gain
        out[n, c + 3] = W[W_MISC][M_SDOT_USED]
