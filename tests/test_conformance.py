"""Conformance over everything registered: plants, designs, failure models, scenarios."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import (
    ClosedLoop,
    DivergenceWarning,
    FuzzyBasis,
    LinearRegressor,
    list_scenarios,
    load_scenario,
    simulate,
)
from adaptive_ftc.controllers import DESIGNS, MimoDirectAdaptive
from adaptive_ftc.faults import FAILURE_MODELS
from adaptive_ftc.plants import PLANTS, ExpressionPlant


def _plant(name):
    """An instance of every registered plant (the equations plant needs its equations)."""
    if PLANTS[name] is ExpressionPlant:
        return ExpressionPlant(
            name="pendulum-equations",
            states=("theta", "omega"),
            outputs={"theta": "omega"},
            actuators=("m1", "m2"),
            parameters={"a": 9.81},
            dynamics={"theta": "omega", "omega": "-a*sin(theta) + m1 + 2*m2"},
        )
    return PLANTS[name]()


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_plant_derivative_shapes_batch_axis_and_no_mutation(name):
    plant = _plant(name)
    rng = np.random.default_rng(0)
    x = rng.normal(0, 0.1, (3, 2, plant.n_states))
    u = rng.normal(0, 0.1, (3, 2, plant.n_actuators))
    x_copy, u_copy = x.copy(), u.copy()
    d = plant.derivative(1.0, x, u)
    assert d.shape == x.shape and np.all(np.isfinite(d))
    assert np.array_equal(x, x_copy) and np.array_equal(u, u_copy)
    # batch evaluation equals one-by-one evaluation
    np.testing.assert_array_equal(d[1, 0], plant.derivative(1.0, x[1, 0], u[1, 0]))
    # outputs have relative degree 2: position' = velocity
    for pi, vi in zip(plant.position_index, plant.velocity_index, strict=True):
        np.testing.assert_array_equal(d[..., pi], x[..., vi])


def _loop_for(plant_name: str, design: str) -> ClosedLoop:
    plant = _plant(plant_name)
    p, m = plant.n_outputs, plant.n_actuators
    cls = DESIGNS[design]
    has_reg = "regressor" in cls.__dataclass_fields__  # the inverse baselines have none
    if p > 1 and design != "mimo" and has_reg:
        pytest.skip("single-output design on a multi-output plant")
    reg = LinearRegressor(inputs=("s1",) if p > 1 else ("e", "edot"))
    kwargs = {"lam": 1.0, "k": 1.0, "k0": 0.1, "eps0": 0.1}
    ctrl = cls(**kwargs, **({"regressor": reg} if has_reg else {}))
    R = np.zeros((p, m))
    for j in range(m):
        R[j * p // m, j] = 1.0
    return ClosedLoop(
        plant=plant,
        controller=ctrl,
        allocation=R if p > 1 else R[0],
        reference=("0.01*sin(t)",) * p,
        t_final=0.5,
    )


@pytest.mark.parametrize("design", sorted(DESIGNS))
@pytest.mark.parametrize("plant_name", sorted(PLANTS))
def test_every_design_runs_on_every_plant_deterministically(plant_name, design):
    loop = _loop_for(plant_name, design)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        a = simulate(loop)
        b = simulate(loop)
    assert np.array_equal(a.states, b.states)
    p, m = loop.plant.n_outputs, loop.plant.n_actuators
    n = a.time.size
    assert a.y.shape == (n, p) and a.u_cmd.shape == (n, m) and a.u_applied.shape == (n, m)
    assert a.states.shape == (n, loop.plant.n_states)
    if a.status == "completed":
        assert np.all(np.isfinite(a.states)) and np.all(np.isfinite(a.adaptive))
    ds = a.to_xarray()
    assert ds["u_cmd"].dims == ("time", "actuator")


@pytest.mark.parametrize("model", sorted(FAILURE_MODELS))
def test_every_failure_model_is_applied_by_the_kernel_as_its_expression(model):
    cls = FAILURE_MODELS[model]
    extra = {
        "parameterised_stuck": {"coefficients": (0.1, 0.05), "basis": ("1", "sin(t)")},
        "position_limit": {"lower": -0.01, "upper": 0.02},
        "nonaffine": {"output": "0.5*u**3 + 0.1*x1"},
        "affine": {"effectiveness": "0.5 + 0.1*sin(t)", "bias": "0.2*x1*x2"},
        "stuck": {"value": "0.1*cos(t)"},
        "bias": {"bias": 0.05},
        "loss_of_effectiveness": {"effectiveness": 0.4},
        "sluggish": {"tau": 0.3},
        "rate_limited": {"rate": 0.05},
    }.get(model, {})
    sc = load_scenario("hypersonic-direct-s1")
    fail = cls(actuator=1, onset=1.0, recovery=3.0, **extra)
    loop = replace(sc.loop, failures=(fail,), t_final=4.0)
    r = simulate(loop)
    if hasattr(fail, "dynamics"):  # a failure of the actuator's motion, not of its output map
        w = r.window(1.0, 2.999)
        rate = np.abs(np.diff(r.u_applied[w, 0])) / np.diff(r.time[w])
        if model == "rate_limited":
            assert rate.max() <= 0.05 * (1 + 1e-6)
        assert np.max(np.abs(r.u_applied[w, 0] - r.u_cmd[w, 0])) > 1e-6  # it lags
        healthy = ~r.window(1.0, 2.999)
        np.testing.assert_allclose(r.u_applied[healthy, 0], r.u_cmd[healthy, 0], atol=0)
        return
    e = fail.expression(("t", "u", "x1", "x2"))
    w = r.window(1.0, 2.999)
    want = e(t=r.time[w], u=r.u_cmd[w, 0], x1=r.states[w, 0], x2=r.states[w, 1])
    np.testing.assert_allclose(r.u_applied[w, 0], want, atol=1e-12)
    healthy = ~r.window(1.0, 2.999)
    np.testing.assert_allclose(r.u_applied[healthy, 0], r.u_cmd[healthy, 0], atol=0)


def test_generated_fuzzy_regressor_matches_the_numpy_implementation():
    from adaptive_ftc.sim.compose import assemble

    sc = load_scenario("hypersonic-direct-s1")
    for normalised in (True, False):
        fls = FuzzyBasis(
            inputs=("alpha", "q"),
            centers=((-1.0, 0.0, 1.0), (-0.5, 0.5)),
            width=0.6,
            normalised=normalised,
        )
        loop = replace(sc.loop, controller=replace(sc.loop.controller, regressor=fls))
        asm = assemble(loop)
        rng = np.random.default_rng(3)
        for _ in range(5):
            z = rng.normal(0, 1, 2)
            y = asm.y0.copy()
            y[:2] = z
            np.testing.assert_allclose(asm.regressor_values(0.0, y), fls(z), rtol=1e-13)


@pytest.mark.parametrize("name", list_scenarios())
def test_every_catalogue_scenario_is_compensable(name):
    sc = load_scenario(name)
    assert sc.loop.compensability().ok or "free" in name
    assert isinstance(sc.loop.controller, tuple(DESIGNS.values()))
    if isinstance(sc.loop.controller, MimoDirectAdaptive):
        assert sc.loop.plant.n_outputs > 1
