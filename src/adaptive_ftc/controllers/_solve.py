"""The guarded linear solve shared by the nominal inverse, the oracle and the constraint-aware
MIMO law's model feedforward (plain Python, compiled into the generated loop modules).

Its own module so that :mod:`~adaptive_ftc.controllers.constraints` can use it without
importing :mod:`~adaptive_ftc.controllers.nominal` (which imports the controllers' base: an
import cycle).
"""

from __future__ import annotations

__all__ = ["solve_guarded"]


def solve_guarded(a, at, n, gmin, out):
    """Solve ``G u0 = v`` for the nominal inverse (plain Python, compiled in the loop).

    ``G`` is stored row-major at ``a[at : at + n*n]`` and ``v`` right after it, at
    ``a[at + n*n : at + n*n + n]``; both are overwritten. Gaussian elimination with partial
    pivoting; a pivot ``d`` with ``|d| < gmin`` is replaced by ``gmin`` with the sign of ``d``
    (``+gmin`` for ``d = 0``). The solution is written to ``out[0:n]``.
    """
    v = at + n * n
    for k in range(n):
        piv = k
        amax = abs(a[at + k * n + k])
        for i in range(k + 1, n):
            val = abs(a[at + i * n + k])
            if val > amax:
                amax = val
                piv = i
        if piv != k:
            for j in range(n):
                tmp = a[at + k * n + j]
                a[at + k * n + j] = a[at + piv * n + j]
                a[at + piv * n + j] = tmp
            tmp = a[v + k]
            a[v + k] = a[v + piv]
            a[v + piv] = tmp
        d = a[at + k * n + k]
        if abs(d) < gmin:
            d = gmin if d >= 0.0 else -gmin
            a[at + k * n + k] = d
        for i in range(k + 1, n):
            factor = a[at + i * n + k] / d
            if factor != 0.0:
                for j in range(k, n):
                    a[at + i * n + j] -= factor * a[at + k * n + j]
                a[v + i] -= factor * a[v + k]
    for i in range(n - 1, -1, -1):
        acc = a[v + i]
        for j in range(i + 1, n):
            acc -= a[at + i * n + j] * out[j]
        out[i] = acc / a[at + i * n + i]
