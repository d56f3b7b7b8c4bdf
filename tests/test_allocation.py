"""Allocators against a truth: scipy's constrained least-squares / QP solutions, and the
adaptive effectiveness estimate converging to the true effectiveness (issue 31)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear, minimize

from adaptive_ftc.allocation import (
    AdaptiveAllocation,
    FixedAllocation,
    PseudoInverse,
    WeightedLeastSquares,
    allocator_from_spec,
    kernels,
)
from adaptive_ftc.errors import ConfigurationError


def _random_case(rng, p, m):
    B = rng.normal(size=(p, m))
    while np.linalg.cond(B) > 50:
        B = rng.normal(size=(p, m))
    return B


def _min_norm_qp(B, v, w):
    """Reference: min sum w_j u_j^2 subject to B u = v (scipy's SLSQP)."""
    res = minimize(
        lambda u: float(np.sum(w * u * u)),
        np.zeros(B.shape[1]),
        jac=lambda u: 2 * w * u,
        constraints=[{"type": "eq", "fun": lambda u: B @ u - v, "jac": lambda u: B}],
        method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 500},
    )
    assert res.success
    return res.x


@pytest.mark.parametrize("seed", range(8))
def test_pinv_matches_weighted_min_norm_qp(seed):
    rng = np.random.default_rng(seed)
    p, m = rng.integers(1, 4), rng.integers(4, 8)
    B = _random_case(rng, p, m)
    v = rng.normal(size=p)
    w = rng.uniform(0.5, 3.0, size=m)
    u = PseudoInverse().allocate(v, B, weights=w)
    np.testing.assert_allclose(u, _min_norm_qp(B, v, w), atol=1e-6)
    np.testing.assert_allclose(B @ u, v, atol=1e-10)


def test_pinv_guard_drops_a_nearly_unreachable_axis_instead_of_huge_gains():
    # hexarotor-like: two axes, the second barely reachable (singular value 1e-5)
    B = np.array([[1.0, 1.0, 1.0, 1.0], [1e-5, -1e-5, 1e-5, -1e-5]])
    v = np.array([1.0, 1.0])
    plain = np.linalg.pinv(B) @ v
    assert np.max(np.abs(plain)) > 1e4  # the naive inverse: huge commands
    u = PseudoInverse(max_condition=1e3).allocate(v, B)
    np.testing.assert_allclose(u, [0.25, 0.25, 0.25, 0.25], atol=1e-9)
    u_all = PseudoInverse(max_condition=1e9).allocate(v, B)
    np.testing.assert_allclose(u_all, plain, rtol=1e-6)


def _wls_reference(B, v, lo, hi, wu, gamma, ud):
    A = np.vstack([np.sqrt(gamma) * B, np.diag(wu)])
    b = np.concatenate([np.sqrt(gamma) * v, wu * ud])
    res = lsq_linear(A, b, bounds=(lo, hi), tol=1e-14, method="bvls")
    return res.x


@pytest.mark.parametrize("seed", range(12))
def test_wls_matches_bounded_least_squares(seed):
    rng = np.random.default_rng(100 + seed)
    p, m = rng.integers(1, 4), rng.integers(3, 8)
    B = _random_case(rng, p, m)
    v = rng.normal(size=p) * 3.0  # often beyond the limits: active constraints
    lo = -rng.uniform(0.2, 1.0, size=m)
    hi = rng.uniform(0.2, 1.0, size=m)
    wu = rng.uniform(0.5, 2.0, size=m)
    gamma = 1e3
    alloc = WeightedLeastSquares(gamma=gamma)
    u, iters = alloc.solve(v, B, limits=(lo, hi), weights=wu)
    assert iters > 0
    ref = _wls_reference(B, v, lo, hi, wu, gamma, np.zeros(m))
    np.testing.assert_allclose(u, ref, atol=1e-7)
    # warm start from the solution: optimal in one iteration
    u2, iters2 = alloc.solve(v, B, limits=(lo, hi), weights=wu, previous=u)
    np.testing.assert_allclose(u2, ref, atol=1e-7)
    assert iters2 == 1


def test_wls_with_iteration_budget_returns_a_feasible_command():
    rng = np.random.default_rng(7)
    B = rng.normal(size=(3, 6))
    lo, hi = -0.1 * np.ones(6), 0.1 * np.ones(6)
    u, iters = WeightedLeastSquares(max_iterations=1).solve([5.0, -5.0, 5.0], B, (lo, hi))
    assert iters == -1
    assert np.all(u >= lo - 1e-12) and np.all(u <= hi + 1e-12)


def test_wls_unbounded_equals_pinv():
    rng = np.random.default_rng(3)
    B, v = _random_case(rng, 3, 6), rng.normal(size=3)
    np.testing.assert_allclose(
        WeightedLeastSquares(gamma=1e8).allocate(v, B), PseudoInverse().allocate(v, B), atol=1e-6
    )


def test_fixed_allocation_is_the_thesis_distribution():
    R = np.array([[1.0, 0, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0], [0, 0, 1, 0, 0, 1]])
    u0 = np.array([0.3, -1.0, 2.0])
    fixed = FixedAllocation(nominal=R)
    np.testing.assert_allclose(fixed.allocate(R @ R.T @ u0), R.T @ u0, atol=1e-15)
    # blind to the failed actuators' B
    np.testing.assert_array_equal(
        fixed.allocate(R @ R.T @ u0, R * [0, 1, 1, 1, 1, 1]), fixed.allocate(R @ R.T @ u0, R)
    )


def test_adaptive_estimate_converges_to_true_effectiveness_under_persistent_excitation():
    R = np.array([[1.0, 0, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0], [0, 0, 1, 0, 0, 1]])
    rho_true = np.array([0.3, 1.0, 0.6, 0.8, 0.0, 0.5])
    alloc = AdaptiveAllocation(gain=20.0, lower=0.0)
    rho = np.ones(6)
    dt = 1e-3
    freqs = np.array([1.0, 1.7, 2.3, 3.1, 3.7, 4.3])
    for k in range(40000):
        t = k * dt
        u = np.sin(freqs * t) + 0.5 * np.cos(2.1 * freqs * t + 1.0)  # persistently exciting
        achieved = R @ (rho_true * u)
        rho = alloc.step(R, rho, u, achieved, dt)
        assert np.all(rho >= 0.0) and np.all(rho <= 1.0)  # the projection holds
    np.testing.assert_allclose(rho, rho_true, atol=2e-3)


def test_adaptive_projection_stops_estimates_at_their_bounds():
    R = np.array([[1.0, 1.0]])
    alloc = AdaptiveAllocation(gain=10.0, lower=0.2, upper=1.0)
    # achieved more than predicted at rho = 1: the estimate would rise, it may not
    np.testing.assert_array_equal(alloc.rate(R, [1.0, 1.0], [1.0, 1.0], [3.0]), [0.0, 0.0])
    np.testing.assert_array_equal(alloc.rate(R, [0.2, 0.2], [1.0, 1.0], [0.0]), [0.0, 0.0])
    assert np.all(alloc.rate(R, [0.5, 0.5], [1.0, 1.0], [0.0]) < 0)


def test_adaptive_allocation_inverts_the_estimated_matrix():
    R = np.array([[1.0, 1.0, 0, 0], [0, 0, 1.0, 1.0]])
    rho = np.array([0.5, 1.0, 1.0, 0.25])
    B = AdaptiveAllocation.estimated(R, rho)
    u = AdaptiveAllocation(inner="pinv").allocate([1.0, 1.0], B)
    np.testing.assert_allclose(R @ (rho * u), [1.0, 1.0], atol=1e-12)


def test_kernels_compile_with_numba_without_reference_counting():
    from numba import njit

    opts = {"_nrt": False, "error_model": "numpy"}
    pinv = njit(**opts)(kernels.pinv_allocate)
    rng = np.random.default_rng(11)
    B, v = _random_case(rng, 3, 6), rng.normal(size=3)
    u = np.zeros(6)
    rank = pinv(B.ravel(), v, np.ones(6), 3, 6, 1e3, u, np.zeros(kernels.pinv_work_size(3, 6)))
    assert rank == 3
    np.testing.assert_allclose(u, PseudoInverse().allocate(v, B), atol=1e-12)
    # the kernel's helpers are module globals: jit them in place for the WLS kernel's call
    wls = njit(**opts)(kernels.wls_allocate)
    lo, hi = -0.3 * np.ones(6), 0.3 * np.ones(6)
    u = np.zeros(6)
    work = np.zeros(kernels.wls_work_size(3, 6))
    wls(B.ravel(), 3 * v, lo, hi, np.ones(6), np.zeros(6), 1e4, 3, 6, 50, u, work)
    np.testing.assert_allclose(
        u, WeightedLeastSquares(gamma=1e4).allocate(3 * v, B, (lo, hi)), atol=1e-12
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "pinvv"}, "Did you mean 'pinv'"),
        ({"kind": "wls", "gamma": -1.0}, "gamma"),
        ({"kind": "wls", "gama": 1.0}, "Allowed: gamma"),
        ({"kind": "adaptive", "lower": 1.0, "upper": 0.5}, "below `upper`"),
        ({"kind": "adaptive", "inner": "qp"}, "Unknown `inner`"),
        ({"kind": "pinv", "max_condition": 0.5}, "max_condition"),
    ],
)
def test_bad_allocator_settings_name_the_culprit(kwargs, match):
    with pytest.raises(ConfigurationError, match=match):
        allocator_from_spec(**kwargs)


def test_limits_in_the_wrong_order_are_refused():
    with pytest.raises(ConfigurationError, match="actuator 2: lower 1 is above upper -1"):
        WeightedLeastSquares().allocate([1.0], [[1.0, 1.0]], limits=([-1, 1], [1, -1]))


@pytest.mark.parametrize(
    "module",
    [
        "adaptive_ftc.allocation.allocators",
        "adaptive_ftc.allocation.reachable",
        "adaptive_ftc.allocation.inloop",
    ],
)
def test_docstring_examples_run(module):
    import doctest
    import importlib

    failures, tried = doctest.testmod(importlib.import_module(module))
    assert tried > 0 and failures == 0
