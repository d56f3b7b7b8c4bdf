"""The adaptive laws shared by the thesis designs, as code (compiled inside each closed loop).

Plain Python in the subset numba compiles: every generated closed-loop module jits these and
calls them from its right-hand side, so the equations live here, once, beside their citations.
Indices passed in (``at``, ``off``, ``size``) locate a parameter block in the closed-loop state.
"""

from __future__ import annotations

import math

__all__ = ["filtered_error", "kappa_law", "robust_q", "theta_law", "weighted_sum"]


def filtered_error(e, edot, lam):
    """Filtered tracking error ``s = e' + lambda e``, eq. (2.18)."""
    return edot + lam * e


def robust_q(sdot, s, k, k0, eps0):
    """``q = s' + k s + k0 tanh(s / eps0)``: the signal every adaptive law is driven by
    (from the Lyapunov derivative of (2.27), with the robust term of (2.20))."""
    return sdot + k * s + k0 * math.tanh(s / eps0)


def weighted_sum(phi, Y, off, at, size):
    """``Pi^T theta`` (2.22): regressor ``phi[off:off+size]`` times ``Y[at:at+size]``."""
    acc = 0.0
    for l in range(size):
        acc += phi[off + l] * Y[at + l]
    return acc


def theta_law(dY, Y, phi, q, gamma, sigma, gain, off, at, size):
    """sigma-modified gradient law ``theta' = gamma g Pi q - gamma sigma theta``:
    (2.29) and (3.37) with ``g = 1``, (4.25) with ``g = N(tau)``, (4.54) with ``g = rho``."""
    for l in range(size):
        dY[at + l] = gamma * gain * phi[off + l] * q - gamma * sigma * Y[at + l]


def kappa_law(dY, Y, w, q, eta2, sigma, off, at, size):
    """Failure-parameter law (2.73): ``kappa_j' = -eta2 varpi_j q - eta2 sigma kappa_j``."""
    for l in range(size):
        dY[at + l] = -eta2 * w[off + l] * q - eta2 * sigma * Y[at + l]
