"""Engine: convergence order, exact restarts at failure times, determinism, divergence, paths."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest
from conftest import assert_close

from adaptive_ftc import (
    ClosedLoop,
    DirectAdaptive,
    DivergenceWarning,
    LinearRegressor,
    SolverOptions,
    Stuck,
    WingRock,
    load_scenario,
    simulate,
    simulate_many,
)
from adaptive_ftc.errors import ConfigurationError

W = 2.0  # natural frequency of the analytic oscillator
STUCK, T_ON = 0.7, 1.2345  # stuck value and an onset that falls between fixed steps


def oscillator(failures=()) -> ClosedLoop:
    """Wing-rock plant reduced to phi'' = -W^2 phi + u1 + u2 + u3, open loop (u0 = 0)."""
    plant = WingRock(a0=W**2, a1=0.0, a2=0.0, a3=0.0, a4=0.0, b=(1.0, 1.0, 1.0))
    ctrl = DirectAdaptive(regressor=LinearRegressor(inputs=(), bias=True), theta0=0.0)
    return ClosedLoop(
        plant=plant,
        controller=ctrl,
        allocation=(0.0, 0.0, 0.0),
        reference=("0",),
        initial_state=(1.0, 0.0),
        failures=failures,
        t_final=4.0,
        adapt=False,
    )


def analytic(t: np.ndarray, stuck: bool) -> np.ndarray:
    x = np.cos(W * t)
    if not stuck:
        return x
    x0, v0 = np.cos(W * T_ON), -W * np.sin(W * T_ON)
    c = STUCK / W**2
    tau = t - T_ON
    after = c + (x0 - c) * np.cos(W * tau) + v0 / W * np.sin(W * tau)
    return np.where(t >= T_ON, after, x)


def test_rk4_is_fourth_order_on_the_harmonic_oscillator():
    errs = []
    for dt in (0.1, 0.05, 0.025):
        r = simulate(oscillator(), SolverOptions(dt=dt, record_dt=0.1))
        errs.append(np.max(np.abs(r.states[:, 0] - analytic(r.time, False))))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 3.8) and np.all(orders < 4.3), orders


def test_restart_at_the_onset_keeps_fourth_order_with_a_jump_between_steps():
    loop = oscillator((Stuck(actuator=1, onset=T_ON, value=STUCK),))
    errs = []
    for dt in (0.1, 0.05, 0.025):
        r = simulate(loop, SolverOptions(dt=dt, record_dt=0.1))
        errs.append(np.max(np.abs(r.states[:, 0] - analytic(r.time, True))))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    # stepping across the jump would give first order (ratio ~2); the restart keeps ~16
    assert np.all(orders > 3.8), orders


def test_variable_step_error_at_the_onset_does_not_depend_on_the_max_step():
    loop = oscillator((Stuck(actuator=1, onset=T_ON, value=STUCK),))
    errs = []
    for max_step in (np.inf, 1.0, 0.1):
        r = simulate(
            loop,
            SolverOptions(
                method="DOP853", rtol=1e-11, atol=1e-12, max_step=max_step, record_dt=0.05
            ),
        )
        errs.append(np.max(np.abs(r.states[:, 0] - analytic(r.time, True))))
    # the jump is integrated exactly whatever the step: all errors are at tolerance level
    assert max(errs) < 1e-8, errs


def test_records_land_on_the_requested_grid_with_failure_times_in_their_own_phase():
    r = simulate(
        oscillator((Stuck(actuator=1, onset=T_ON, value=STUCK),)),
        SolverOptions(dt=0.01, record_dt=0.05),
    )
    assert_close(r.time, np.arange(0, 4.0001, 0.05), atol=1e-12)
    on = r.time >= T_ON
    assert_close(r.u_applied[on, 0], STUCK, atol=0)
    assert_close(r.u_applied[~on, 0], 0.0, atol=0)


def test_same_inputs_give_identical_results_sequential_or_parallel():
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=20.0)
    a = simulate(loop, sc.solver)
    b = simulate(loop, sc.solver)
    assert np.array_equal(a.states, b.states) and np.array_equal(a.adaptive, b.adaptive)
    many = simulate_many([loop, loop], sc.solver, jobs=2)
    assert all(np.array_equal(m.states, a.states) for m in many)


def test_rk4_agrees_with_the_accurate_path_on_a_thesis_scenario():
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=60.0)
    fast = simulate(loop, sc.solver)
    acc = simulate(loop, SolverOptions(method="accurate", record_dt=0.01))
    assert_close(fast.states, acc.states, atol=1e-6)


def test_divergence_stops_with_a_clear_message_and_keeps_the_partial_result():
    loop = oscillator((Stuck(actuator=1, onset=1.0, value=1e12),))
    with pytest.warns(DivergenceWarning, match=r"diverged at t = .* signal 'phi"):
        r = simulate(loop, SolverOptions(dt=0.01, divergence_bound=1e6))
    assert r.status == "diverged"
    assert 1.0 <= r.time[-1] < 4.0
    assert np.all(np.isfinite(r.states)) and np.all(np.abs(r.states) < 1e6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        ra = simulate(loop, SolverOptions(method="RK45", divergence_bound=1e6))
    assert ra.status == "diverged" and "phi" in ra.message


def test_filtered_sdot_mode_tracks_close_to_the_exact_mode():
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=40.0)
    exact = simulate(loop, sc.solver)
    filt = simulate(loop, replace(sc.solver, sdot="filtered", filter_tau=0.005))
    assert filt.status == "completed"
    assert filt.rms_error(20, 40)[0] < 5 * exact.rms_error(20, 40)[0] + 1e-3
    assert "s_filter1" in filt.adaptive_names


def test_solver_options_are_validated():
    with pytest.raises(ConfigurationError, match="Did you mean 'rk4'"):
        SolverOptions(method="rk5")
    with pytest.raises(ConfigurationError, match="`dt` of SolverOptions must be positive"):
        SolverOptions(dt=0.0)
