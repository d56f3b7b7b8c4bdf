"""Real actuators, sensors and digital control (issue 14) against exact solutions.

One plant serves every test: a double integrator ``x'' = u1 + u2`` with two actuators, driven by
a non-adaptive controller whose command is known in closed form (a linear regressor with
frozen parameters), so each behaviour has an analytic truth.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import pytest

from adaptive_ftc import ClosedLoop, DirectAdaptive, LinearRegressor, SolverOptions, simulate
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import LossOfEffectiveness, RateLimited, Sluggish
from adaptive_ftc.hardware import RATE_ONLY_TAU, Actuators, Sensors
from adaptive_ftc.plants import plant
from adaptive_ftc.sim.compose import assemble


class _P(NamedTuple):
    b: float


def double_integrator_equations(t, x, u, p, xdot):
    """x'' = b (u1 + u2)."""
    xdot[0] = x[1]
    xdot[1] = p.b * (u[0] + u[1])


# plant(...) called, not used as a decorator: the module keeps the equations under their own
# name (both forms give disk-cached loops; test_open_engine checks the decorated one).
double_integrator = plant(
    states=("pos", "vel"),
    outputs={"pos": "vel"},
    actuators=("left", "right"),
    params=_P(b=1.0),
    name="double_integrator",
)(double_integrator_equations)


ACCURATE = SolverOptions(method="dopri5", rtol=1e-11, atol=1e-13, record_dt=0.01)


def _loop(theta, inputs=(), **kw) -> ClosedLoop:
    """``u0 = theta . [1, inputs...]`` frozen; both actuators get ``u = u0 / 2``."""
    return ClosedLoop(
        plant=double_integrator,
        controller=DirectAdaptive(regressor=LinearRegressor(inputs=inputs, bias=True)),
        allocation=(0.5, 0.5),
        reference=("0",),
        adapt=False,
        adaptive_initial=tuple(theta),
        **{"t_final": 1.0, **kw},
    )


def _clipped_first_order(t, target, tau, rate, a0=0.0):
    """Exact a(t) of a' = clip((target - a)/tau, -rate, rate) from a0 < target - rate tau."""
    t1 = (target - rate * tau - a0) / rate  # end of the rate-limited ramp
    return np.where(t < t1, a0 + rate * t, target - rate * tau * np.exp(-(t - t1) / tau))


def test_rate_limited_lagged_actuator_follows_the_exact_step_response():
    loop = _loop((2.0,), actuators=Actuators(tau=0.1, rate=2.0, initial=(0.0, 0.0)))
    r = simulate(loop, ACCURATE)
    assert r.status == "completed"
    assert np.all(r.u_cmd == 1.0)  # the step command, 2.0 split over two actuators
    exact = _clipped_first_order(r.time, 1.0, 0.1, 2.0)
    np.testing.assert_allclose(r.u_applied[:, 0], exact, atol=1e-8)
    np.testing.assert_allclose(r.u_applied[:, 1], exact, atol=1e-8)
    # and the plant integrates the actuator position, not the command
    vel = np.concatenate([[0.0], np.cumsum(np.diff(r.time) * 0.5 * (exact[1:] + exact[:-1]))])
    np.testing.assert_allclose(r.states[:, 1], 2 * vel, atol=2e-4)  # trapezoid on 0.01 s


def test_per_actuator_position_limits_saturate_the_applied_output():
    loop = _loop((2.0,), actuators=Actuators(upper=(0.25, math.inf)))
    r = simulate(loop, ACCURATE)
    np.testing.assert_allclose(r.u_applied[:, 0], 0.25)
    np.testing.assert_allclose(r.u_applied[:, 1], 1.0)
    np.testing.assert_allclose(r.states[-1, 1], 1.25, rtol=1e-9)  # v(1) = (0.25 + 1) * 1 s


def test_without_initial_positions_actuators_start_at_their_first_command():
    r = simulate(_loop((2.0,), actuators=Actuators(tau=0.05)), ACCURATE)
    np.testing.assert_allclose(r.u_applied, 1.0, atol=1e-12)  # no start-up transient


def test_dynamics_failures_equal_the_same_declared_actuator_dynamics():
    sluggish = _loop((2.0,), failures=(Sluggish(actuator=1, onset=0.0, tau=0.1),))
    declared = _loop((2.0,), actuators=Actuators(tau=(0.1, 0.0)))
    a, b = simulate(sluggish, ACCURATE), simulate(declared, ACCURATE)
    np.testing.assert_array_equal(a.u_applied, b.u_applied)
    limited = _loop(
        (2.0,), failures=(RateLimited(actuator=2, onset=0.0, rate=3.0),), actuators=Actuators()
    )
    r = simulate(replace(limited, actuators=Actuators(initial=(1.0, 0.0))), ACCURATE)
    exact = _clipped_first_order(r.time, 1.0, RATE_ONLY_TAU, 3.0)
    np.testing.assert_allclose(r.u_applied[:, 1], exact, atol=1e-8)


def test_a_sluggish_onset_mid_run_starts_from_where_the_actuator_is():
    # a growing command u0 = vel, with vel' = u0: vel = exp(t)
    loop = _loop(
        (0.0, 1.0),
        inputs=("vel",),
        initial_state=(0.0, 1.0),
        failures=(Sluggish(actuator=1, onset=0.5, tau=0.2),),
    )
    r = simulate(loop, ACCURATE)
    k = int(np.searchsorted(r.time, 0.5))
    jump = abs(r.u_applied[k, 0] - r.u_applied[k - 1, 0])
    step = abs(r.u_applied[k - 1, 0] - r.u_applied[k - 2, 0])
    assert jump <= 1.5 * step  # continuous through the onset: no jump back to 0
    assert r.u_applied[-1, 0] < r.u_cmd[-1, 0]  # lags the growing command afterwards


def test_zero_order_hold_matches_the_exact_discretisation():
    """A digital PD-like law on x'' = u: x_{k+1} = Phi x_k + Gamma u_k exactly."""
    T = 0.05
    theta = (0.3, -4.0, -2.0)  # u0 = 0.3 - 4 pos - 2 vel (measured at the samples)
    loop = _loop(theta, inputs=("pos", "vel"), initial_state=(1.0, 0.0), sample_time=T)
    loop = replace(loop, t_final=2.0)
    r = simulate(loop, SolverOptions(method="rk4", dt=T / 7, record_dt=T, sdot="exact"))
    assert r.status == "completed"
    phi = np.array([[1.0, T], [0.0, 1.0]])
    gam = np.array([T * T / 2, T])
    x = np.array([1.0, 0.0])
    expect = [x]
    for _ in range(len(r.time) - 1):
        u = theta[0] + theta[1] * x[0] + theta[2] * x[1]
        x = phi @ x + gam * u
        expect.append(x)
    np.testing.assert_allclose(r.states, np.array(expect), rtol=0, atol=1e-12)
    # the command recorded at each sample is the one computed there (the last record, at the
    # end of the run, still holds the command of the last sample)
    ex = np.array(expect)
    u_k = theta[0] + theta[1] * ex[:, 0] + theta[2] * ex[:, 1]
    np.testing.assert_allclose(2 * r.u_cmd[:-1, 0], u_k[:-1], atol=1e-12)
    assert 2 * r.u_cmd[-1, 0] == pytest.approx(u_k[-2], abs=1e-12)


def test_failure_times_within_rounding_of_a_sample_instant_replace_it():
    from adaptive_ftc.sim.compose import _intervals

    T = 0.05
    onset = 10 * T + 1e-13  # at the 10th sample, up to rounding
    fails = (
        LossOfEffectiveness(actuator=1, onset=onset, effectiveness=0.5, recovery=20 * T - 1e-13),
        LossOfEffectiveness(actuator=2, onset=onset - 4e-13, effectiveness=0.5),
        LossOfEffectiveness(actuator=2, onset=0.7 * T, effectiveness=0.5, recovery=2 * T),
    )
    loop = replace(_loop((0.0,), sample_time=T, failures=fails), t_final=2.0)
    bps, on_grid, k = _intervals(loop)
    # one interval per sample period; the failure times stand in for their sample instants
    # (the later of two within rounding), and 0.7 T adds one interval off the grid
    grid = {float(t) for t in T * np.arange(40)}
    expect = sorted(grid - {10 * T, 20 * T} | {onset, 20 * T - 1e-13, 0.7 * T, 2.0})
    assert list(bps) == expect
    assert len(bps) == 42 and onset - 4e-13 not in bps
    starts = np.asarray(bps[:-1])
    assert on_grid.tolist() == [int(not math.isclose(t, 0.7 * T)) for t in starts]
    assert k.tolist() == [int(math.floor(t / T + 1e-9)) for t in starts]


def test_digital_adaptive_law_is_forward_euler_at_the_samples():
    """Between samples theta moves along the derivative computed at the sample: straight."""
    loop = ClosedLoop(
        plant=double_integrator,
        controller=DirectAdaptive(regressor=LinearRegressor(inputs=("e",)), gamma=3.0),
        allocation=(0.5, 0.5),
        reference=("sin(t)",),
        t_final=1.0,
        sample_time=0.1,
    )
    r = simulate(loop, SolverOptions(method="rk4", dt=0.01, record_dt=0.01, filter_tau=0.1))
    th = r.adaptive[:, 0]
    for k in range(10):  # samples at 0.0, 0.1, ...: theta is affine on each interval
        seg = th[10 * k : 10 * k + 11]
        np.testing.assert_allclose(np.diff(seg, 2), 0.0, atol=1e-12)


def test_measurement_noise_has_the_declared_statistics_and_seed():
    sensors = Sensors(noise={"pos": 0.01, "vel": 0.2}, bias={"pos": 0.05}, rate=1000.0, seed=4)
    loop = _loop((0.0,), sensors=sensors, t_final=10.0)
    meas = assemble(loop, sdot="filtered").data.meas
    assert meas.shape == (10_000, 2)
    n = meas.shape[0]
    # sample std within 3 standard errors of the declared value (chi-square, n large)
    for i, (mean, std) in enumerate(((0.05, 0.01), (0.0, 0.2))):
        assert abs(meas[:, i].mean() - mean) < 3 * std / math.sqrt(n)
        assert abs(meas[:, i].std() / std - 1) < 3 / math.sqrt(2 * n)
    assert abs(np.corrcoef(meas[:-1, 1], meas[1:, 1])[0, 1]) < 3 / math.sqrt(n)  # white
    same = assemble(loop, sdot="filtered").data.meas
    other = assemble(replace(loop, sensors=replace(sensors, seed=5)), sdot="filtered").data.meas
    np.testing.assert_array_equal(meas, same)
    assert not np.allclose(meas, other)
    # a shorter run sees the same noise at the same times
    short = assemble(replace(loop, t_final=1.0), sdot="filtered").data.meas
    np.testing.assert_array_equal(short, meas[:1000])


def test_the_controller_sees_the_measurement_and_the_result_the_true_error():
    sensors = Sensors(noise={"pos": 0.1}, seed=1, rate=100.0)
    loop = _loop((0.0, 1.0), inputs=("pos",), sensors=sensors, initial_state=(0.3, 0.0))
    asm = assemble(loop, sdot="filtered")
    y = asm.y0.copy()
    for k in (0, 7, 42):
        t = k / 100.0 + 0.004  # inside sample interval k
        phi = asm.regressor_values(t, y, phase=k)
        assert phi[1] == pytest.approx(0.3 + asm.data.meas[k, 0], abs=1e-15)
    r = simulate(loop, SolverOptions(method="rk4", dt=1e-3))
    assert r.meta["sdot"] == "filtered"  # the honest default with noise
    np.testing.assert_allclose(r.e[:, 0], r.yd[:, 0] - r.y[:, 0], atol=1e-15)


def test_bad_hardware_settings_are_clear_errors():
    with pytest.raises(ConfigurationError, match="unknown state 'alpha'"):
        _loop((0.0,), sensors=Sensors(noise={"alpha": 0.1}))
    with pytest.raises(ConfigurationError, match="standard deviation"):
        _loop((0.0,), sensors=Sensors(noise={"pos": -1.0}))
    with pytest.raises(ConfigurationError, match="one value per actuator"):
        _loop((0.0,), actuators=Actuators(tau=(0.1, 0.2, 0.3)))
    with pytest.raises(ConfigurationError, match="below `upper`"):
        _loop((0.0,), actuators=Actuators(lower=1.0, upper=0.0))
    with pytest.raises(ConfigurationError, match="sample_time"):
        _loop((0.0,), sample_time=-0.1)
    with pytest.raises(ConfigurationError, match="no incipient form"):
        Sluggish(actuator=1, onset=1.0, ramp=0.5, tau=0.1)
    with pytest.raises(ConfigurationError, match="filter_tau"):
        simulate(_loop((0.0,), sample_time=0.05), SolverOptions(sdot="filtered", filter_tau=0.01))


def test_interop_refuses_sampled_loops():
    pytest.importorskip("control")
    from adaptive_ftc.interop import to_control

    with pytest.raises(ConfigurationError, match="jumps at every sample"):
        to_control(_loop((0.0,), sample_time=0.1))


def test_loss_of_effectiveness_acts_on_the_actuator_position():
    loop = _loop(
        (2.0,),
        actuators=Actuators(tau=0.1, initial=(0.0, 0.0)),
        failures=(LossOfEffectiveness(actuator=1, onset=0.0, effectiveness=0.5),),
    )
    r = simulate(loop, ACCURATE)
    exact = 1.0 - np.exp(-r.time / 0.1)
    np.testing.assert_allclose(r.u_applied[:, 0], 0.5 * exact, atol=1e-9)
    np.testing.assert_allclose(r.u_applied[:, 1], exact, atol=1e-9)


def test_scenario_files_declare_actuators_sensors_and_digital_control(tmp_path):
    from adaptive_ftc.errors import ScenarioError
    from adaptive_ftc.scenarios import load_scenario

    text = """
extends = "hypersonic-direct-s1"
name = "hw"
[actuators]
tau = [0.05, 0.02]
rate = 20.0
upper = 1.0
[sensors]
noise = {alpha = 1e-4, q = 1e-3}
bias = {alpha = 1e-5}
seed = 3
[digital]
sample_time = 0.005
"""
    path = tmp_path / "hw.toml"
    path.write_text(text)
    loop = load_scenario(path).loop
    assert loop.actuators == Actuators(tau=(0.05, 0.02), rate=20.0, upper=1.0)
    assert loop.sensors.noise == {"alpha": 1e-4, "q": 1e-3} and loop.sensors.seed == 3
    assert loop.sample_time == 0.005
    path.write_text(text.replace("seed = 3", "sead = 3"))
    with pytest.raises(ScenarioError, match="sensors.*unknown key 'sead'"):
        load_scenario(path)
    path.write_text(text.replace("alpha = 1e-4", "alfa = 1e-4"))
    with pytest.raises(ScenarioError, match="unknown state 'alfa'"):
        load_scenario(path)
    path.write_text(text.replace("sample_time = 0.005", "sample_time = -1"))
    with pytest.raises(ScenarioError, match="digital"):
        load_scenario(path)


def test_too_many_samples_are_refused_before_anything_is_allocated():
    with pytest.raises(ConfigurationError, match="samples, more than the limit"):
        simulate(replace(_loop((0.0,), sample_time=1e-9), t_final=100.0))
    with pytest.raises(ConfigurationError, match="noise `rate`"):
        loop = _loop((0.0,), sensors=Sensors(noise=(0.1, 0.0), rate=1e9), t_final=100.0)
        simulate(loop)


def test_python_control_export_of_a_loop_with_actuator_lag_matches_the_simulation():
    ct = pytest.importorskip("control")
    from adaptive_ftc.interop import control_initial_state, to_control

    loop = _loop((0.0, -2.0, -1.0), inputs=("pos", "vel"), initial_state=(1.0, 0.0))
    loop = replace(loop, actuators=Actuators(tau=0.2), t_final=3.0)
    r = simulate(loop, ACCURATE)
    sys = to_control(loop)
    x0 = control_initial_state(loop)
    assert x0.size == 2 + 3 + 2  # pos, vel, theta, the actuators (at their first command)
    np.testing.assert_allclose(x0[-2:], r.u_applied[0], atol=1e-15)
    resp = ct.input_output_response(
        sys, r.time, 0.0, x0, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12}
    )
    np.testing.assert_allclose(np.atleast_2d(resp.outputs)[0], r.y[:, 0], atol=1e-7)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rate": 0.0}, "`rate` of Actuators must be > 0"),
        ({"tau": -0.1}, "`tau` of Actuators must be > 0"),
        ({"tau": True}, "must be numbers"),
        ({"initial": (0.1,)}, "one value per actuator"),
    ],
)
def test_actuator_values_are_checked(kwargs, match):
    with pytest.raises(ConfigurationError, match=match):
        _loop((0.0,), actuators=Actuators(**kwargs))


def test_sensor_noise_must_be_a_table_or_a_list():
    with pytest.raises(ConfigurationError, match="table by state name"):
        Sensors(noise=1e-4)


def test_second_order_actuator_follows_the_exact_underdamped_step_response():
    w, z = 20.0, 0.3
    loop = _loop((2.0,), actuators=Actuators(omega=w, zeta=z, initial=(0.0, 0.0)))
    r = simulate(loop, ACCURATE)
    wd = w * math.sqrt(1 - z * z)
    t = r.time
    exact = 1 - np.exp(-z * w * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t))
    np.testing.assert_allclose(r.u_applied[:, 0], exact, atol=1e-8)
    # with a rate limit the position never moves faster than it
    limited = simulate(replace(loop, actuators=replace(loop.actuators, rate=5.0)), ACCURATE)
    speed = np.abs(np.diff(limited.u_applied[:, 0])) / np.diff(limited.time)
    assert speed.max() <= 5.0 * (1 + 1e-9) and speed.max() > 4.9
    with pytest.raises(ConfigurationError, match="both a lag"):
        _loop((0.0,), actuators=Actuators(tau=0.1, omega=10.0))
