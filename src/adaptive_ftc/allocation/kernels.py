"""Allocation kernels: plain loops over preallocated arrays, compilable by numba without
reference counting (``njit(_nrt=False)``) so that a generated closed loop can call them in its
right-hand side, and runnable as plain Python.

Every matrix is a flat, row-major array: the effectiveness matrix ``B`` (p x m) is ``B[i * m + j]``.
Nothing here allocates: each kernel receives a ``work`` array of at least the size that its
``*_work_size`` function gives. Each kernel is self-contained (no call to another function of
this module), so that numba compiles it from its own source wherever it is jitted, and
importing this module does not import numba.
"""

from __future__ import annotations

import math

__all__ = [
    "actuator_effectiveness_rate",
    "adaptive_effectiveness_rate",
    "pinv_allocate",
    "pinv_work_size",
    "wls_allocate",
    "wls_work_size",
]


def pinv_work_size(p: int, m: int) -> int:
    """Length of the ``work`` array of :func:`pinv_allocate`."""
    return 2 * p * p + 2 * p


def pinv_allocate(B, v, w, p, m, max_condition, u, work):
    """Weighted minimum-norm allocation ``u = W^-1 B^T (B W^-1 B^T)^+ v`` with a conditioning
    guard; returns the number of axes kept (the numerical rank).

    ``w`` holds the positive weights ``W`` per actuator (``min sum w_j u_j^2`` subject to
    ``B u = v``). The Gram matrix ``B W^-1 B^T`` is inverted on its eigen-directions whose
    singular value (of ``W^-1/2 B``) is at least ``sigma_max / max_condition``: a direction
    the actuators can no longer reach (a rank loss) or barely reach (near singular) gets no
    command at all instead of a huge one (the hexarotor's 50-2000x gains of PX4 #28589).
    """
    G = work[0 : p * p]
    Q = work[p * p : 2 * p * p]
    y = work[2 * p * p : 2 * p * p + p]
    z = work[2 * p * p + p : 2 * p * p + 2 * p]
    for a in range(p):
        for b in range(p):
            acc = 0.0
            for j in range(m):
                acc += B[a * m + j] * B[b * m + j] / w[j]
            G[a * p + b] = acc
    # eigen-decomposition of G by cyclic Jacobi rotations: G's diagonal ends as the
    # eigenvalues, Q's columns as the eigenvectors
    n = p
    for i in range(n):
        for j in range(n):
            Q[i * n + j] = 1.0 if i == j else 0.0
    for _ in range(30):
        off = 0.0
        for i in range(n):
            for j in range(i + 1, n):
                off += G[i * n + j] * G[i * n + j]
        if off == 0.0:
            break
        for a in range(n):
            for b in range(a + 1, n):
                gab = G[a * n + b]
                if abs(gab) <= 1e-300 + 1e-16 * (abs(G[a * n + a]) + abs(G[b * n + b])):
                    G[a * n + b] = 0.0  # negligible: the rotation would be the identity
                    G[b * n + a] = 0.0
                    continue
                theta = (G[b * n + b] - G[a * n + a]) / (2.0 * gab)
                if abs(theta) > 1e150:  # theta^2 would overflow: t ~ 1 / (2 theta)
                    t = 0.5 / theta
                else:
                    t = (1.0 if theta >= 0.0 else -1.0) / (
                        abs(theta) + math.sqrt(theta * theta + 1.0)
                    )
                cs = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * cs
                for k in range(n):  # G <- G J (columns a, b)
                    gka = G[k * n + a]
                    gkb = G[k * n + b]
                    G[k * n + a] = cs * gka - sn * gkb
                    G[k * n + b] = sn * gka + cs * gkb
                for k in range(n):  # G <- J^T G (rows a, b)
                    gak = G[a * n + k]
                    gbk = G[b * n + k]
                    G[a * n + k] = cs * gak - sn * gbk
                    G[b * n + k] = sn * gak + cs * gbk
                for k in range(n):  # Q <- Q J
                    qka = Q[k * n + a]
                    qkb = Q[k * n + b]
                    Q[k * n + a] = cs * qka - sn * qkb
                    Q[k * n + b] = sn * qka + cs * qkb
    lam_max = 0.0
    for k in range(p):
        if G[k * p + k] > lam_max:
            lam_max = G[k * p + k]
    cut = lam_max / (max_condition * max_condition)
    rank = 0
    for k in range(p):  # y = Q^T v, scaled by 1/lambda on the kept directions
        acc = 0.0
        for i in range(p):
            acc += Q[i * p + k] * v[i]
        lam = G[k * p + k]
        if lam_max > 0.0 and lam >= cut and lam > 0.0:
            y[k] = acc / lam
            rank += 1
        else:
            y[k] = 0.0
    for i in range(p):  # z = Q y = G^+ v
        acc = 0.0
        for k in range(p):
            acc += Q[i * p + k] * y[k]
        z[i] = acc
    for j in range(m):
        acc = 0.0
        for i in range(p):
            acc += B[i * m + j] * z[i]
        u[j] = acc / w[j]
    return rank


def wls_work_size(p: int, m: int) -> int:
    """Length of the ``work`` array of :func:`wls_allocate`."""
    return m * m + 4 * m + p


def wls_allocate(B, v, lo, hi, wu, ud, gamma, p, m, max_iter, u, work):
    """Härkegård's weighted least-squares allocation by an active-set method.

    Solves ``min ||Wu (u - ud)||^2 + gamma ||B u - v||^2`` subject to ``lo <= u <= hi``
    (Härkegård, "Efficient active set algorithms for solving constrained least squares
    problems in aircraft control allocation", CDC 2002: the ``wls_alloc`` of flight firmware).
    ``u`` holds the warm start on entry (the previous command: its components at a bound start
    in the working set) and the solution on return. At most ``max_iter`` iterations; returns
    the number used, or ``-1`` when the limit was reached first (``u`` is then feasible but
    not optimal).
    """
    H = work[0 : m * m]
    ws = work[m * m : m * m + m]  # working set: -1 at lower, +1 at upper, 0 free
    g = work[m * m + m : m * m + 2 * m]
    step = work[m * m + 2 * m : m * m + 3 * m]
    rhs = work[m * m + 3 * m : m * m + 4 * m]
    r = work[m * m + 4 * m : m * m + 4 * m + p]
    tol = 1e-12
    for j in range(m):
        if u[j] <= lo[j]:
            u[j] = lo[j]
            ws[j] = -1.0
        elif u[j] >= hi[j]:
            u[j] = hi[j]
            ws[j] = 1.0
        else:
            ws[j] = 0.0
        if lo[j] == hi[j]:
            ws[j] = -1.0
    for it in range(max_iter):
        # r = v - B u and g = -gradient/2 = gamma B^T r + wu^2 (ud - u)
        for i in range(p):
            acc = v[i]
            for j in range(m):
                acc -= B[i * m + j] * u[j]
            r[i] = acc
        for j in range(m):
            acc = wu[j] * wu[j] * (ud[j] - u[j])
            for i in range(p):
                acc += gamma * B[i * m + j] * r[i]
            g[j] = acc
        # the step on the free set: (gamma B_F^T B_F + Wu_F^2) s = g_F
        nf = 0
        for a in range(m):
            if ws[a] != 0.0:
                continue
            nb = 0
            for b in range(a + 1):
                if ws[b] != 0.0:
                    continue
                acc = 0.0
                for i in range(p):
                    acc += B[i * m + a] * B[i * m + b]
                acc *= gamma
                if a == b:
                    acc += wu[a] * wu[a]
                H[nf * m + nb] = acc
                nb += 1
            rhs[nf] = g[a]
            nf += 1
        # Cholesky factorisation H = L L^T (in place, lower triangle), then two solves
        for a in range(nf):
            for b in range(a + 1):
                sc = H[a * m + b]
                for k in range(b):
                    sc -= H[a * m + k] * H[b * m + k]
                if a == b:
                    if sc <= 0.0:
                        return -1  # not positive definite (a weight of 0)
                    H[a * m + a] = math.sqrt(sc)
                else:
                    H[a * m + b] = sc / H[b * m + b]
        for a in range(nf):  # forward: L y = rhs
            sc = rhs[a]
            for k in range(a):
                sc -= H[a * m + k] * step[k]
            step[a] = sc / H[a * m + a]
        for a in range(nf - 1, -1, -1):  # backward: L^T x = y
            sc = step[a]
            for k in range(a + 1, nf):
                sc -= H[k * m + a] * step[k]
            step[a] = sc / H[a * m + a]
        # scatter the step onto all actuators (0 on the working set)
        k = nf - 1
        for j in range(m - 1, -1, -1):
            if ws[j] == 0.0:
                step[j] = step[k]
                k -= 1
            else:
                step[j] = 0.0
        # the largest feasible fraction of the step, and the bound that stops it
        alpha = 1.0
        hit = -1
        for j in range(m):
            if ws[j] != 0.0:
                continue
            if step[j] > tol and u[j] + step[j] > hi[j]:
                a_j = (hi[j] - u[j]) / step[j]
                if a_j < alpha:
                    alpha, hit = a_j, j
            elif step[j] < -tol and u[j] + step[j] < lo[j]:
                a_j = (lo[j] - u[j]) / step[j]
                if a_j < alpha:
                    alpha, hit = a_j, j
        if hit >= 0:  # blocked: move to the bound and add it to the working set
            for j in range(m):
                u[j] += alpha * step[j]
            ws[hit] = 1.0 if step[hit] > 0.0 else -1.0
            u[hit] = hi[hit] if ws[hit] > 0.0 else lo[hit]
            continue
        for j in range(m):
            u[j] += step[j]
        # optimal on this working set: check the multipliers lambda_j = ws_j g_j
        for i in range(p):
            acc = v[i]
            for j in range(m):
                acc -= B[i * m + j] * u[j]
            r[i] = acc
        worst = -1
        lam_min = -1e-9
        for j in range(m):
            if ws[j] == 0.0 or lo[j] == hi[j]:
                continue
            acc = wu[j] * wu[j] * (ud[j] - u[j])
            for i in range(p):
                acc += gamma * B[i * m + j] * r[i]
            lam = ws[j] * acc
            if lam < lam_min:
                lam_min, worst = lam, j
        if worst < 0:
            return it + 1
        ws[worst] = 0.0
    return -1


def adaptive_effectiveness_rate(R, rho, u, achieved, gain, lower, upper, p, m, rate):
    """Right-hand side of the effectiveness estimate ``rho_hat`` of each actuator, with the
    element-wise projection that keeps each estimate in ``[lower_j, upper_j]``.

    Model ``v = R diag(rho) u`` (the achieved virtual control of the commands ``u``); the
    gradient law ``rho_hat' = gain diag(u) R^T (v - R diag(rho_hat) u)`` minimises the
    prediction error, and the projection stops an estimate at a bound when its rate would
    push it out (Tohidi, Yildiz & Kolmanovsky, "Adaptive control allocation for constrained
    systems", Automatica 2020, whose allocator projects its estimates element-wise onto sets
    consistent with the actuators' limits; here the estimates are effectiveness levels, so
    the set is ``[lower, upper]``, e.g. ``[0, 1]``). The estimate converges to the true
    effectiveness when the commands are persistently exciting.
    """
    for j in range(m):
        acc = 0.0
        for i in range(p):
            pred = 0.0
            for k in range(m):
                pred += R[i * m + k] * rho[k] * u[k]
            acc += R[i * m + j] * (achieved[i] - pred)
        d = gain[j] * u[j] * acc
        if (rho[j] <= lower[j] and d < 0.0) or (rho[j] >= upper[j] and d > 0.0):
            d = 0.0
        rate[j] = d


def actuator_effectiveness_rate(rho, u, delivered, gain, lower, upper, m, rate):
    """Right-hand side of the effectiveness estimates when each actuator's delivered output is
    measured (a reaction wheel's torque from its speed, a motor's from its current): the
    gradient law ``rho_hat_j' = gain_j u_j (delivered_j - rho_hat_j u_j)`` with the same
    element-wise projection onto ``[lower_j, upper_j]`` as :func:`adaptive_effectiveness_rate`.

    Unlike the law on the achieved virtual control, each estimate is identifiable on its own:
    two actuators of one axis that receive the same command (as ``R^T u0`` gives them) are told
    apart.
    """
    for j in range(m):
        d = gain[j] * u[j] * (delivered[j] - rho[j] * u[j])
        if (rho[j] <= lower[j] and d < 0.0) or (rho[j] >= upper[j] and d > 0.0):
            d = 0.0
        rate[j] = d
