"""python-control interop: the exported closed loop and plant against our own simulation."""

from dataclasses import replace

import numpy as np
import pytest

control = pytest.importorskip("control")

from adaptive_ftc import ConfigurationError, SolverOptions, load_scenario, simulate  # noqa: E402
from adaptive_ftc.interop import (  # noqa: E402
    control_initial_state,
    piecewise_response,
    plant_to_control,
    to_control,
)

TIGHT = SolverOptions(method="dopri5", rtol=1e-11, atol=1e-13, record_dt=0.05)
PC_TOL = {"rtol": 1e-8, "atol": 1e-11}


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("hypersonic-direct-s1")


@pytest.fixture(scope="module")
def reference(scenario):
    """Our simulation of the full 120 s (both failures) with tight tolerances."""
    return simulate(scenario.loop, TIGHT)


def _states(result):
    return np.hstack([result.states, result.adaptive])


def test_closed_loop_layout(scenario):
    loop = scenario.loop
    sys = to_control(loop)
    assert sys.ninputs == 0
    assert sys.output_labels == ["alpha"]
    res = simulate(replace(loop, t_final=0.1), TIGHT)
    assert sys.state_labels == [*loop.plant.state_names, *res.adaptive_names]
    x0 = control_initial_state(loop)
    assert x0.shape == (sys.nstates,)
    np.testing.assert_array_equal(x0[:2], loop.initial_state)
    np.testing.assert_allclose(x0[2:], loop.controller.theta0)


def test_before_first_failure_plain_input_output_response(scenario, reference):
    """On [0, first failure) there is no jump: python-control's own call matches."""
    loop = scenario.loop
    first = loop.failures.breakpoints(loop.t0, loop.t_final)[1]
    sel = reference.time < first
    resp = control.input_output_response(
        to_control(loop),
        reference.time[sel],
        initial_state=control_initial_state(loop),
        solve_ivp_kwargs=PC_TOL,
    )
    assert resp.success
    err = np.abs(resp.states.T - _states(reference)[sel]).max()
    assert err < 1e-8, err  # measured 1e-10 at these tolerances
    np.testing.assert_allclose(np.ravel(resp.outputs), reference.y[sel, 0], rtol=0, atol=1e-10)


def test_piecewise_response_matches_simulate_across_failures(scenario, reference):
    """Integrated one failure interval at a time, the export matches the whole 120 s."""
    resp = piecewise_response(scenario.loop, reference.time, solve_ivp_kwargs=PC_TOL)
    assert resp.states.shape == (_states(reference).shape[1], reference.time.size)
    err = np.abs(resp.states.T - _states(reference)).max()
    assert err < 1e-7, err
    np.testing.assert_allclose(np.ravel(resp.outputs), reference.y[:, 0], rtol=0, atol=1e-9)
    # and the catalogue's own fixed-step RK4 run agrees to its step error
    rk4 = simulate(scenario.loop, replace(scenario.solver, record_dt=0.05))
    assert np.abs(resp.states.T - _states(rk4)).max() < 1e-5


def test_plant_export_matches_plant_derivative(scenario):
    plant = scenario.loop.plant
    sys = plant_to_control(plant)
    assert sys.input_labels == list(plant.actuator_names)
    assert sys.state_labels == list(plant.state_names)
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.normal(scale=0.1, size=plant.n_states)
        u = rng.normal(scale=0.2, size=plant.n_actuators)
        t = float(rng.uniform(0, 100))
        np.testing.assert_allclose(sys.dynamics(t, x, u), plant.derivative(t, x, u), rtol=1e-14)
        np.testing.assert_allclose(sys.output(t, x, u), x[list(plant.position_index)])
    # python-control's linearisation sees the same actuator effect as Plant.input_gains
    lin = control.linearize(sys, np.zeros(plant.n_states), np.zeros(plant.n_actuators))
    np.testing.assert_allclose(
        np.asarray(lin.B)[list(plant.velocity_index), :], plant.input_gains(), rtol=1e-5
    )


def test_bad_arguments_are_clear(scenario):
    with pytest.raises(ConfigurationError, match="needs a ClosedLoop"):
        to_control(scenario.loop.plant)
    with pytest.raises(ConfigurationError, match="needs a Plant"):
        plant_to_control(scenario.loop)
    with pytest.raises(ConfigurationError, match="within the loop"):
        piecewise_response(scenario.loop, [0.0, 500.0])
