"""The compiled adaptive-step integrators (sim/templates/adaptive.py) against exact solutions.

One test right-hand side serves every problem (``D[0]`` picks it), so the template compiles once.
"""

from __future__ import annotations

import dis
import importlib
import math
import re
import threading
import time
from pathlib import Path

import numba
import numpy as np
import pytest

from adaptive_ftc.sim.templates import adaptive

METHODS = ("dopri5", "rodasp", "rodas5p", "auto")
ORDERS = {"dopri5": 5, "rodasp": 4, "rodas5p": 5}

# stiff linear problem y' = A y, eigenvalues -1 and -1e5 (A = P diag(-1, -1e5) P^-1)
_P = np.array([[1.0, 1.0], [1.0, -1.0]])
_A = _P @ np.diag([-1.0, -1e5]) @ np.linalg.inv(_P)


@numba.njit
def _rhs(t, Y, ph, D, W, dY):
    kind = int(D[0])
    W[0][0] += 1.0  # the work arrays reach rhs
    if kind == 0:  # linear y' = A y, A = [[D1, D2], [D3, D4]]
        dY[0] = D[1] * Y[0] + D[2] * Y[1]
        dY[1] = D[3] * Y[0] + D[4] * Y[1]
    elif kind == 1:  # y' = -2 t y^2, y = 1 / (1 + t^2);  z' = -z + cos t
        dY[0] = -2.0 * t * Y[0] * Y[0]
        dY[1] = -Y[1] + math.cos(t)
    elif kind == 2:  # piecewise y' = -k_ph y, z' = c_ph (phase-dependent)
        dY[0] = -D[1 + ph] * Y[0]
        dY[1] = D[5 + ph]
    elif kind == 3:  # y' = y^2 (blows up at t = 1 / y0);  z' = 0
        dY[0] = Y[0] * Y[0]
        dY[1] = 0.0
    elif kind == 4:  # y' = 1 / (t - 0.5): a singularity no step size resolves
        dY[0] = 1.0 / (t - 0.5)
        dY[1] = 0.0
    elif kind == 6:  # stiff, nonlinear, coupled: y relaxes at rate D[1] to z^2
        dY[0] = -D[1] * (Y[0] - Y[1] * Y[1])
        dY[1] = -Y[1] + math.cos(t) + 0.1 * Y[0]
    else:  # Prothero-Robinson y' = L (y - cos t) - sin t, L = -1e4; z' = -z^2
        dY[0] = -1e4 * (Y[0] - math.cos(t)) - math.sin(t)
        dY[1] = -Y[1] * Y[1]


@numba.njit
def _make_work(D):
    return (np.zeros(1),)


@pytest.fixture(scope="module")
def mod():
    return adaptive.bind(_rhs, _make_work, name="test_solvers_integrators")


def solve(mod, method, y0, breaks, t_rec, D, rtol=1e-8, atol=1e-10, bound=1e8, stop=None):
    n = len(y0)
    Y = np.zeros((len(t_rec), n))
    phase = np.full(len(t_rec), -1, dtype=np.int64)
    stats = np.zeros(5, dtype=np.int64)
    stop = np.zeros(1, dtype=np.int64) if stop is None else stop
    nrec, status, t_stop, bad = getattr(mod, f"integrate_{method}")(
        np.asarray(y0, dtype=float),
        np.asarray(breaks, dtype=float),
        np.asarray(t_rec, dtype=float),
        np.asarray(D, dtype=float),
        (np.zeros(1),),
        float(rtol),
        np.broadcast_to(np.asarray(atol, dtype=float), (n,)).copy(),
        math.inf,
        float(bound),
        stop,
        Y,
        phase,
        stats,
    )
    return Y, phase, int(nrec), int(status), float(t_stop), int(bad), stats


def assert_close(actual, expected, atol):
    err = np.max(np.abs(np.asarray(actual) - np.asarray(expected)))
    assert err <= atol, f"max error {err:.3e} > {atol:.1e}"


def test_template_text_is_what_follows_the_marker_with_one_core_per_method():
    text = adaptive.template_text()
    source = Path(adaptive.__file__).read_text()
    assert source.count(adaptive.TEMPLATE_MARKER + "\n") == 1
    pasted = source.split(adaptive.TEMPLATE_MARKER + "\n", 1)[1]
    assert adaptive.specialise(pasted) == text
    assert "def integrate_dopri5(" in text and "def bind(" not in text
    assert "def _solve(" not in text
    steps = {name: f"_steps_{name.removeprefix('integrate_')}" for name, *_ in adaptive._CORES}
    for name, loop in steps.items():  # each entry point drives its own copy of the step loop
        assert loop in _names_used(text, name)
    names = {name: _names_used(text, loop) for name, loop in steps.items()}
    # each copy keeps only its own method's steps once Python drops dead blocks
    dopri5, rosenbrock = {"_dopri5_step", "_dopri5_control"}, {"_rosenbrock_step", "_jacobian"}
    assert dopri5 <= names["integrate_dopri5"] and not rosenbrock & names["integrate_dopri5"]
    assert rosenbrock <= names["integrate_rodasp"] and not dopri5 & names["integrate_rodasp"]
    assert rosenbrock <= names["integrate_rodas5p"] and not dopri5 & names["integrate_rodas5p"]
    assert dopri5 | rosenbrock | {"_stiffness_test"} <= names["integrate_auto"]
    assert "_stiffness_test" not in names["integrate_dopri5"]
    # the cores are the entry points: no wrapper makes numba link and optimise them twice
    assert not re.search(r"\b_solve_(dopri5|rodasp|rodas5p|auto)\b", text)


def _names_used(text: str, name: str) -> set[str]:
    """Global names that function ``name`` of ``text`` loads (its bytecode, so not those of
    blocks Python dropped)."""
    source = f"@jit\ndef {name}(" + text.split(f"def {name}(", 1)[1].split("\n\n\n", 1)[0]
    ns = {"jit": lambda f: f}
    exec(source, ns)  # noqa: S102
    code = ns[name].__code__
    return {i.argval for i in dis.get_instructions(code) if i.opname == "LOAD_GLOBAL"}


@pytest.mark.parametrize("method", METHODS)
def test_nonlinear_nonautonomous_problem_meets_the_tolerance(mod, method):
    t_rec = np.linspace(0.0, 5.0, 51)
    exact = np.c_[1.0 / (1.0 + t_rec**2), 0.5 * (np.cos(t_rec) + np.sin(t_rec) - np.exp(-t_rec))]
    Y, phase, nrec, status, t_stop, bad, stats = solve(
        mod, method, [1.0, 0.0], [0.0, 5.0], t_rec, [1.0], rtol=1e-8, atol=1e-10
    )
    assert (nrec, status, t_stop, bad) == (51, 0, 5.0, -1)
    assert (phase == 0).all()
    assert_close(Y, exact, 1e-7)
    assert stats[0] > 0 and stats[2] > stats[0]


@pytest.mark.parametrize("method", ["dopri5", "rodasp", "rodas5p"])
def test_convergence_order(mod, method):
    """Global error against steps taken falls with the slope of the method's order."""
    t_rec = np.array([0.0, 5.0])
    errs, steps = [], []
    for tol in (1e-6, 1e-9):
        Y, *_, stats = solve(mod, method, [1.0, 0.0], [0.0, 5.0], t_rec, [1.0], tol, tol * 1e-2)
        exact = [1.0 / 26.0, 0.5 * (math.cos(5.0) + math.sin(5.0) - math.exp(-5.0))]
        errs.append(np.max(np.abs(Y[-1] - exact)))
        steps.append(stats[0])
    slope = -math.log(errs[1] / errs[0]) / math.log(steps[1] / steps[0])
    assert ORDERS[method] - 1.0 <= slope <= ORDERS[method] + 1.5, (slope, errs, steps)


def test_stiff_linear_problem_against_exact_solution(mod):
    """Eigenvalues -1 and -1e5: the Rosenbrock method takes few steps, DOPRI5 is step-bound."""
    t_rec = np.linspace(0.0, 2.0, 21)
    y0 = np.array([2.0, 0.5])
    lam = np.array([-1.0, -1e5])
    c = np.linalg.solve(_P, y0)
    exact = (_P @ (c[:, None] * np.exp(np.outer(lam, t_rec)))).T
    D = [0.0, *_A.ravel()]
    Ys, _, _, status, *_, stats_s = solve(mod, "rodasp", y0, [0.0, 2.0], t_rec, D, 1e-7, 1e-9)
    assert status == 0
    assert_close(Ys, exact, 1e-6)
    assert stats_s[0] < 300
    # one Jacobian per accepted step (a rejected step reuses it), one LU per attempt
    assert stats_s[3] == stats_s[0] and stats_s[4] == stats_s[0] + stats_s[1]
    Ye, _, _, status, *_, stats_e = solve(mod, "dopri5", y0, [0.0, 2.0], t_rec, D, 1e-7, 1e-9)
    assert status == 0
    assert_close(Ye, exact, 1e-6)
    assert stats_e[0] > 50 * stats_s[0]  # stability-limited: h < 3.3e-5
    Ya, _, _, status, *_, stats_a = solve(mod, "auto", y0, [0.0, 2.0], t_rec, D, 1e-7, 1e-9)
    assert status == 0
    assert_close(Ya, exact, 1e-6)
    assert stats_a[3] > 0 and stats_a[0] < stats_e[0] / 10  # switched to the stiff method


def test_transposed_lu_solves_against_numpy(mod):
    """``_lu_factor`` of ``A^T`` then ``_lu_solve_t`` / ``_lu_solve_t2`` solve ``A x = b``
    (the core factors the transpose of ``I / (gamma h) - J``), with pivoting exercised."""
    rng = np.random.default_rng(12)
    for n in (1, 2, 5, 14, 27):
        A = rng.normal(size=(n, n))
        if n > 1:
            A[0, 0] = 0.0  # forces a row swap at the first column
        b, c = rng.normal(size=n), rng.normal(size=n)
        F = A.T.copy()
        piv = np.zeros(n, dtype=np.int64)
        dinv = np.zeros(n)
        assert mod._lu_factor(F, piv, dinv)
        x = b.copy()
        mod._lu_solve_t(F, piv, dinv, x)
        np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
        x2, y2 = b.copy(), c.copy()
        mod._lu_solve_t2(F, piv, dinv, x2, y2)
        np.testing.assert_array_equal(x2, x)  # same arithmetic as the one-vector solve
        np.testing.assert_allclose(y2, np.linalg.solve(A, c), rtol=1e-10, atol=1e-12)
    singular = np.ones((3, 3))
    assert not mod._lu_factor(singular, np.zeros(3, np.int64), np.zeros(3))


def test_rodasp_time_derivative_skipped_only_where_the_loop_does_not_move(mod):
    """An autonomous loop needs n + 1 evaluations per Jacobian (f(t + delt, y) equals f(t, y)
    bit for bit, so df/dt = 0), a time-dependent one n + 2 (central difference)."""
    n = 2

    def extra(stats, per_jacobian):
        # evaluations left after the 2 at the start, the Jacobians and 5 per attempt: one per
        # attempt passing the error test (f(y1)), one more where a record lies inside a step
        return stats[2] - 2 - per_jacobian * stats[3] - 5 * (stats[0] + stats[1])

    t_rec = np.array([0.0, 2.0])
    D = [0.0, *_A.ravel()]  # y' = A y: autonomous
    *_, status, _, _, stats = solve(mod, "rodasp", [2.0, 0.5], [0.0, 2.0], t_rec, D, 1e-7, 1e-9)
    assert status == 0
    assert stats[0] <= extra(stats, n + 1) <= stats[0] + stats[1] + 1
    # Prothero-Robinson: depends on t
    *_, status, _, _, stats = solve(mod, "rodasp", [2.0, 1.0], [0.0, 2.0], t_rec, [5.0], 1e-7, 1e-9)
    assert status == 0
    assert stats[0] <= extra(stats, n + 2) <= stats[0] + stats[1] + 1


def test_prothero_robinson_stiff_component_dense_output(mod):
    """Recorded (interpolated) values of a stiff component stay within the tolerance."""
    t_rec = np.linspace(0.0, 10.0, 1001)
    exact = np.c_[np.cos(t_rec) + np.exp(-1e4 * t_rec), 1.0 / (1.0 + t_rec)]
    Y, _, nrec, status, *_, stats = solve(
        mod, "rodasp", [2.0, 1.0], [0.0, 10.0], t_rec, [5.0], 1e-6, 1e-8
    )
    assert status == 0 and nrec == t_rec.size
    assert_close(Y[1:], exact[1:], 2e-6)
    # the 3rd-order dense output over the ~0.13 s steps the step error alone allows is off by
    # 5e-4; the dense-output check shortens them (about 120 steps, not the 1000 of a cap at the
    # record spacing)
    assert 80 < stats[0] < 300


def test_rodas5p_dense_output_on_the_prothero_robinson_problem(mod):
    """Rodas5P's 4th-order dense output keeps every record within the tolerance, in fewer
    steps than RODASP (whose 3rd-order interpolant limits its steps between records)."""
    t_rec = np.linspace(0.0, 10.0, 1001)
    exact = np.c_[np.cos(t_rec) + np.exp(-1e4 * t_rec), 1.0 / (1.0 + t_rec)]
    runs = {}
    for method in ("rodasp", "rodas5p"):
        Y, _, nrec, status, *_, stats = solve(
            mod, method, [2.0, 1.0], [0.0, 10.0], t_rec, [5.0], 1e-6, 1e-8
        )
        assert status == 0 and nrec == t_rec.size
        assert_close(Y[1:], exact[1:], 2e-6)
        runs[method] = stats.copy()
    assert runs["rodas5p"][0] < runs["rodasp"][0]
    # 7 stage evaluations per attempt (8 stages, the first at f(y0))
    s = runs["rodas5p"]
    assert s[3] == s[0] and s[4] == s[0] + s[1]


@pytest.mark.parametrize("method", ["rodasp", "rodas5p"])
def test_stiff_nonlinear_problem_against_scipy_radau(mod, method):
    """y' = -1e4 (y - z^2), z' = -z + cos t + 0.1 y (eigenvalues near -1e4 and -1): every
    record, nearly all from the dense output, within 1e-7 of scipy's Radau at rtol 1e-12,
    in a few hundred steps."""
    from scipy.integrate import solve_ivp

    k = 1e4
    t_rec = np.linspace(0.0, 10.0, 1001)

    def f(t, y):
        return [-k * (y[0] - y[1] ** 2), -y[1] + math.cos(t) + 0.1 * y[0]]

    def jac(t, y):
        return [[-k, 2.0 * k * y[1]], [0.1, -1.0]]

    ref = solve_ivp(
        f, (0.0, 10.0), [2.0, 0.5], method="Radau", t_eval=t_rec, rtol=1e-12, atol=1e-14,
        jac=jac,
    )  # fmt: skip
    assert ref.status == 0
    Y, _, nrec, status, *_, stats = solve(
        mod, method, [2.0, 0.5], [0.0, 10.0], t_rec, [6.0, k], 1e-7, 1e-9
    )
    assert status == 0 and nrec == t_rec.size
    assert_close(Y, ref.y.T, 1e-7)
    assert stats[0] < 2000


@pytest.mark.parametrize("method", METHODS)
def test_per_state_atol_controls_each_state(mod, method):
    """``atol`` per state (rtol negligible): the state with the tight ``atol`` stays as
    accurate as with both tight, a thousand times better than with both loose, and the loose
    ``atol`` of the other state saves steps (y = 1 / (1 + t^2) and z against their exact
    solutions)."""
    t_rec = np.linspace(0.0, 5.0, 51)
    exact = np.c_[1.0 / (1.0 + t_rec**2), 0.5 * (np.cos(t_rec) + np.sin(t_rec) - np.exp(-t_rec))]
    out = {}
    for key, atol in (
        ("tight", [1e-11, 1e-11]),
        ("loose", [1e-4, 1e-4]),
        ("y tight", [1e-11, 1e-4]),
        ("z tight", [1e-4, 1e-11]),
    ):
        Y, _, _, status, *_, stats = solve(
            mod, method, [1.0, 0.0], [0.0, 5.0], t_rec, [1.0], 1e-14, atol
        )
        assert status == 0
        out[key] = (np.abs(Y - exact).max(axis=0), stats[0])
    for key, i in (("y tight", 0), ("z tight", 1)):
        err, steps = out[key]
        assert err[i] < 1e-8 and out["loose"][0][i] > 1e-6, (key, err, out["loose"][0])
        assert steps < out["tight"][1], (key, steps, out["tight"][1])


def test_solver_options_atol_per_state_is_validated():
    from adaptive_ftc import SolverOptions
    from adaptive_ftc.errors import ConfigurationError

    s = SolverOptions(method="rodas5p", atol=[1e-8, 2e-10, 1e-6])
    assert s.atol == (1e-8, 2e-10, 1e-6) and hash(s) == hash(SolverOptions(**vars(s)))
    np.testing.assert_array_equal(s.atol_for(3), [1e-8, 2e-10, 1e-6])
    np.testing.assert_array_equal(SolverOptions(atol=1e-9).atol_for(2), [1e-9, 1e-9])
    with pytest.raises(
        ConfigurationError, match=r"has 3 entries but the loop has 2 states \(a, b\)"
    ):
        s.atol_for(2, ["a", "b"])
    for bad, msg in (
        ([], "empty"),
        ([1e-8, 0.0], r"atol\[1\]` .* positive"),
        ([1e-8, "x"], r"atol\[1\]` .* number"),
        ([math.nan], "positive and finite"),
        (-1e-9, "positive"),
    ):
        with pytest.raises(ConfigurationError, match=msg):
            SolverOptions(atol=bad)


def test_auto_stays_explicit_on_a_nonstiff_problem(mod):
    Y, *_, stats = solve(mod, "auto", [1.0, 0.0], [0.0, 5.0], np.array([0.0, 5.0]), [1.0])
    assert stats[3] == 0 and stats[4] == 0


@pytest.mark.parametrize("method", METHODS)
def test_exact_restart_at_breaks_and_phase_of_records(mod, method):
    """y' = -k_ph y, z' = c_ph with k, c changing at t = 1 and 2.5 (a kink the steps must not
    cross); a record at a break time belongs to the phase that starts there."""
    k = [1.0, 3.0, 0.5]
    c = [1.0, -2.0, 4.0]
    D = [2.0, *k, 0.0, *c]
    breaks = [0.0, 1.0, 2.5, 4.0]
    t_rec = np.linspace(0.0, 4.0, 17)  # 0.25 apart: 1.0 and 2.5 are record times
    y, z = np.empty_like(t_rec), np.empty_like(t_rec)
    y0, z0 = 1.0, 0.0
    for ph in range(3):
        a, b = breaks[ph], breaks[ph + 1]
        sel = (t_rec >= a) & ((t_rec < b) if ph < 2 else (t_rec <= b))
        y[sel] = y0 * np.exp(-k[ph] * (t_rec[sel] - a))
        z[sel] = z0 + c[ph] * (t_rec[sel] - a)
        y0, z0 = y0 * math.exp(-k[ph] * (b - a)), z0 + c[ph] * (b - a)
    Y, phase, nrec, status, t_stop, bad, _ = solve(mod, method, [1.0, 0.0], breaks, t_rec, D)
    assert (nrec, status, t_stop, bad) == (17, 0, 4.0, -1)
    assert_close(Y[:, 0], y, 1e-8)
    assert_close(Y[:, 1], z, 1e-9)
    expected_phase = np.searchsorted(np.array(breaks[1:-1]), t_rec, side="right")
    np.testing.assert_array_equal(phase, expected_phase)
    assert phase[4] == 1 and phase[10] == 2  # t = 1.0 and t = 2.5


def _rk4_module():
    path = Path(adaptive.__file__).with_name("rk4.py")
    if not path.exists():
        pytest.skip("templates/rk4.py (the fixed-step template) is not there")
    text = path.read_text().split(adaptive.TEMPLATE_MARKER + "\n", 1)[1]
    # the names its header stands in for (decorators, imports), with our rhs
    ns = {k: v for k, v in vars(importlib.import_module(f"{adaptive.__package__}.rk4")).items()}
    ns["rhs"] = _rhs
    ns["jump"] = numba.njit(adaptive._no_jump)
    ns["leaves_envelope"] = numba.njit(adaptive._no_envelope)
    exec(compile(text, str(path), "exec"), ns)  # noqa: S102
    return ns


def test_recording_semantics_match_rk4(mod):
    """Same number of records, same phases, same values (to the tolerance) as fixed-step RK4,
    on a grid whose points fall on breaks, between steps and past the last break."""
    ns = _rk4_module()
    D = np.array([2.0, 1.0, 3.0, 0.5, 0.0, 1.0, -2.0, 4.0])
    breaks = np.array([0.0, 1.0, 2.5, 4.0])
    t_rec = np.r_[np.arange(0.0, 4.0, 0.3), 1.0, 2.5, 4.0]
    t_rec.sort()
    Y4 = np.zeros((t_rec.size, 2))
    ph4 = np.full(t_rec.size, -1, dtype=np.int64)
    res = ns["integrate_rk4"](
        np.array([1.0, 0.0]), breaks, 1e-3, t_rec, D, (np.zeros(1),), 1e8,
        np.zeros(1, dtype=np.int64), Y4, ph4, np.zeros(5, dtype=np.int64), *np.empty((8, 2)),
    )  # fmt: skip
    for method in METHODS:
        Y, phase, nrec, status, t_stop, *_ = solve(mod, method, [1.0, 0.0], breaks, t_rec, D)
        assert (nrec, status, t_stop) == (int(res[0]), int(res[1]), float(res[2]))
        np.testing.assert_array_equal(phase, ph4)
        assert_close(Y, Y4, 1e-8)


@pytest.mark.parametrize("method", METHODS)
def test_divergence_reports_the_state(mod, method):
    Y, phase, nrec, status, t_stop, bad, _ = solve(
        mod, method, [1.0, 0.0], [0.0, 2.0], np.linspace(0.0, 2.0, 21), [3.0], bound=1e6
    )
    assert status == 1 and bad == 0
    assert 0.999 < t_stop < 1.0  # y = 1 / (1 - t) passes 1e6 at t = 1 - 1e-6
    assert nrec == 10  # records up to 0.9; the one at 1.0 is never reached
    assert np.all(np.abs(Y[:nrec, 0]) < 1e6)


def test_non_finite_initial_state_is_divergence_at_t0(mod):
    *_, nrec, status, t_stop, bad, _ = solve(
        mod, "dopri5", [0.0, math.nan], [0.0, 1.0], np.linspace(0.0, 1.0, 3), [1.0]
    )
    assert (nrec, status, t_stop, bad) == (0, 1, 0.0, 1)


@pytest.mark.parametrize("method", METHODS)
def test_unresolvable_singularity_is_step_underflow(mod, method):
    *_, nrec, status, t_stop, bad, _ = solve(
        mod, method, [0.0, 0.0], [0.0, 1.0], np.linspace(0.0, 1.0, 11), [4.0]
    )
    assert status == 2 and bad == -1
    assert 0.49 < t_stop <= 0.5 and nrec == 5


@pytest.mark.parametrize("method", METHODS)
def test_stop_flag_set_before_the_run_interrupts_at_once(mod, method):
    stop = np.ones(1, dtype=np.int64)
    *_, nrec, status, t_stop, bad, stats = solve(
        mod, method, [1.0, 0.0], [0.0, 5.0], np.linspace(0.0, 5.0, 6), [1.0], stop=stop
    )
    assert (nrec, status, t_stop, bad) == (1, 3, 0.0, -1)  # only the record at t0
    assert stats[0] == 0


def test_stop_flag_from_another_thread_interrupts_a_running_integration(mod):
    """The integrators release the GIL and poll ``stop`` every step (Ctrl-C in the engine)."""
    stop = np.zeros(1, dtype=np.int64)
    out = {}
    # DOPRI5 on the Prothero-Robinson problem over 1e4 s: its step stays below 3.3e-4 (the
    # stability bound of the fast mode), so ~3e7 steps, far longer than the test waits
    D = [5.0]
    solve(mod, "dopri5", [1.0, 1.0], [0.0, 1e-3], np.array([0.0]), D)  # compiled before timing

    def target():
        out["res"] = solve(
            mod, "dopri5", [1.0, 1.0], [0.0, 1e4], np.array([0.0, 1e4]), D, stop=stop
        )

    worker = threading.Thread(target=target)
    worker.start()
    time.sleep(0.2)
    stop[0] = 1
    worker.join(timeout=20.0)
    assert not worker.is_alive()
    *_, nrec, status, t_stop, bad, stats = out["res"]
    assert status == 3 and 0.0 < t_stop < 1e4 and nrec == 1 and stats[0] > 0


def test_scenario_solver_table_takes_one_atol_per_state(tmp_path):
    """``[solver] atol`` as a list: one number per state of the loop, checked at load time."""
    from adaptive_ftc import load_scenario
    from adaptive_ftc.errors import ScenarioError

    head = 'name = "x"\nextends = "wingrock-estimation-s2"\n[solver]\n'
    good = tmp_path / "good.toml"
    good.write_text(head + f"atol = [{', '.join(['1e-9'] * 13)}, 1e-11]\n")
    assert load_scenario(good).solver.atol == (1e-9,) * 13 + (1e-11,)
    for body, msg in (
        ("atol = [1e-9, 1e-9]", r"has 2 entries but the loop has 14 states \(phi, phi_dot,"),
        ('atol = [1e-9, "x"]', "atol"),
        ("atol = [1e-9, -1.0]", "atol"),
    ):
        bad = tmp_path / "bad.toml"
        bad.write_text(head + body + "\n")
        with pytest.raises(ScenarioError, match=msg):
            load_scenario(bad)


def test_simulate_with_one_atol_per_state_equals_the_scalar_atol():
    """The engine passes every compiled integrator one atol per state: the same number
    repeated gives the scalar's trajectory bit for bit; a wrong count is refused."""
    import dataclasses

    from adaptive_ftc import load_scenario, simulate
    from adaptive_ftc.errors import ConfigurationError

    sc = load_scenario("wingrock-estimation-s2")
    loop = dataclasses.replace(sc.loop, t_final=1.0)
    scalar = simulate(loop, sc.solver)
    n = scalar.states.shape[1] + scalar.adaptive.shape[1]
    per_state = simulate(loop, dataclasses.replace(sc.solver, atol=[sc.solver.atol] * n))
    np.testing.assert_array_equal(per_state.states, scalar.states)
    np.testing.assert_array_equal(per_state.adaptive, scalar.adaptive)
    with pytest.raises(ConfigurationError, match=f"has 3 entries but the loop has {n} states"):
        simulate(loop, dataclasses.replace(sc.solver, atol=[1e-9] * 3))
