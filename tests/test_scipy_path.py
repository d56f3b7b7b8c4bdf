"""The scipy path (any solve_ivp method): stiff methods on the catalogue loops, its statistics.

Issue 26: Radau, BDF and LSODA estimate the Jacobian by finite differences and pass the
right-hand side columns of a matrix (non-contiguous vectors); the compiled ``rhs`` of a loop
with a failure pattern that is not affine takes C-contiguous vectors only and raised a numba
TypingError. The scipy path also reported 0 steps and 0 right-hand side evaluations.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import pytest

from adaptive_ftc import SolverOptions, load_scenario, simulate
from adaptive_ftc.sim.compose import assemble
from tests.conftest import assert_close

#: scenarios whose loops call a non-affine failure pattern through its address (the loops the
#: TypingError hit), with their tracked output
_STIFF_CASES = ("hypersonic-direct-s1", "wingrock-free-1deg", "spacecraft-mimo-s1")


def _short(name: str, t_final: float):
    sc = load_scenario(name)
    return sc, replace(sc.loop, t_final=t_final)


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
@pytest.mark.parametrize("name", _STIFF_CASES)
def test_stiff_scipy_methods_run_and_agree_with_the_compiled_rosenbrock(name, method):
    sc, loop = _short(name, 0.5)
    tol = dict(rtol=1e-8, atol=1e-10)
    ref = simulate(loop, replace(sc.solver, method="rodas5p", **tol))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no divergence, no numba warning
        r = simulate(loop, replace(sc.solver, method=method, **tol))
    assert r.status == "completed", r.message
    assert r.time.shape == ref.time.shape
    # two independent integrators at rtol 1e-8 agree far below the signals' scale
    assert_close(r.states, ref.states, atol=1e-5, rtol=1e-5, what=f"{name} {method}")
    # statistics of an implicit method: steps, Jacobians, LU decompositions, every rhs call
    assert r.meta["steps"] > 0
    if method != "LSODA":  # LSODA needs a Jacobian only once it switches to BDF
        assert r.meta["lu_decompositions"] >= r.meta["jacobian_evaluations"] > 0
    assert r.meta["rhs_evaluations"] > r.meta["steps"]
    assert "rejected_steps" not in r.meta  # scipy does not count them for implicit methods


@pytest.mark.parametrize(("method", "stages"), [("RK45", 6), ("RK23", 3), ("DOP853", 12)])
def test_explicit_scipy_statistics_account_for_every_rhs_call(method, stages):
    """Each attempted step of an explicit Runge-Kutta method costs ``stages`` calls of the
    right-hand side, and each interval of fixed failure pattern 2 more (the derivative at its
    start and the initial step size guess): the counts must add up exactly."""
    sc, loop = _short("hypersonic-direct-s1", 2.0)
    n_intervals = len(assemble(loop).breakpoints) - 1
    r = simulate(loop, replace(sc.solver, method=method, rtol=1e-6, atol=1e-8))
    assert r.status == "completed", r.message
    steps, rejected = r.meta["steps"], r.meta["rejected_steps"]
    assert steps > 0 and rejected >= 0
    # DOP853's dense output costs 3 more calls per step that lands a record inside it
    dense = r.meta["rhs_evaluations"] - stages * (steps + rejected) - 2 * n_intervals
    if method == "DOP853":
        assert 0 < dense <= 3 * steps and dense % 3 == 0
    else:
        assert dense == 0
    assert r.meta["jacobian_evaluations"] == r.meta["lu_decompositions"] == 0


def test_compiled_paths_report_jacobians_and_lu_decompositions():
    sc, loop = _short("hypersonic-direct-s1", 2.0)
    rosenbrock = simulate(loop, replace(sc.solver, method="rodasp"))
    assert rosenbrock.meta["lu_decompositions"] >= rosenbrock.meta["jacobian_evaluations"] > 0
    assert rosenbrock.meta["rejected_steps"] >= 0
    rk4 = simulate(loop, SolverOptions(method="rk4", dt=1e-3))
    assert rk4.meta["steps"] == 2000 and rk4.meta["rhs_evaluations"] >= 4 * 2000
    assert rk4.meta["jacobian_evaluations"] == rk4.meta["lu_decompositions"] == 0
