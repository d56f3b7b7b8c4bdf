"""The registry (adaptive_ftc.registry) and its checkers, run over everything registered
(issue 27, "registries with checkers"); the severity of a failure is the model's own."""

from __future__ import annotations

import dataclasses
import inspect
import math
from typing import ClassVar

import numpy as np
import pytest

from adaptive_ftc import baselines, controllers, faults, load_scenario, plants
from adaptive_ftc._units import actuator_unit, display, state_unit
from adaptive_ftc.controllers import DirectAdaptive
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import Bias, LossOfEffectiveness, NonAffine, PositionLimit, Stuck
from adaptive_ftc.plants import ExpressionPlant, Plant, WingRock
from adaptive_ftc.registry import (
    BASELINES,
    DESIGNS,
    FAILURE_MODELS,
    PLANTS,
    SOLVERS,
    check_design,
    check_failure_model,
    check_plant,
)
from adaptive_ftc.sim import ClosedLoop, SolverOptions

#: Settings a registered part needs beyond its defaults to be a valid sample.
FAILURE_SETTINGS = {
    "parameterised_stuck": {"coefficients": (0.1, 0.05), "basis": ("1", "sin(t)")},
    "sluggish": {"tau": 0.3},
    "rate_limited": {"rate": 0.05},
    "nonaffine": {"output": "0.5*u**3 - 0.1"},
}


def _plant(name: str) -> Plant:
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


#: A catalogue scenario of each registered design (the baselines: of the direct design).
DESIGN_SCENARIOS = {
    "direct": "wingrock-direct-s1",
    "estimation": "wingrock-estimation-s1",
    "mimo": "manipulator-mimo-s1",
    "nussbaum": "pendulum-nussbaum-reversed",
    "sign": "pendulum-sign-reversed",
    "nominal-inverse": "wingrock-direct-s1",
    "oracle": "wingrock-direct-s1",
}


def _design_loop(name: str) -> tuple[ClosedLoop, SolverOptions]:
    """A closed loop of design ``name`` and its solver: a catalogue scenario's (a baseline's:
    built from it)."""
    sc = load_scenario(DESIGN_SCENARIOS[name])
    if name in BASELINES:
        return baselines.baseline_loop(sc.loop, name), baselines.baseline_solver(name, sc.solver)
    return sc.loop, sc.solver


# ----------------------------------------------------------------------- the tables


def test_registry_tables_are_the_packages_tables_read_only():
    assert dict(PLANTS) == plants.PLANTS and dict(DESIGNS) == controllers.DESIGNS
    assert dict(FAILURE_MODELS) == faults.FAILURE_MODELS
    assert tuple(BASELINES) == baselines.BASELINES
    assert tuple(n for n, b in BASELINES.items() if b.fair) == baselines.FAIR_BASELINES
    with pytest.raises(TypeError):
        PLANTS["mine"] = WingRock  # type: ignore[index]


def test_every_solver_is_accepted_by_solver_options_and_nothing_else():
    for method in SOLVERS:
        assert SolverOptions(method=method).method == method
    with pytest.raises(ConfigurationError, match="Use one of"):
        SolverOptions(method="rk5")


def test_registered_names_are_the_names_the_parts_give_themselves():
    assert all(cls.model == key for key, cls in FAILURE_MODELS.items())
    assert all(cls.design == key for key, cls in DESIGNS.items())
    assert all(_plant(key).name == key for key in PLANTS if key != "equations")


@pytest.mark.parametrize("name", sorted(BASELINES))
def test_every_baseline_builds_its_loop_from_the_adaptive_one(name):
    loop, _ = _design_loop("direct")
    solver = SolverOptions(method="dopri5")
    out = BASELINES[name].make(loop, solver)
    assert isinstance(out, ClosedLoop) and out.plant == loop.plant and out != loop
    assert baselines.baseline_loop(loop, name, solver) == out


# ----------------------------------------------------------------------- the checkers


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_every_registered_plant_passes_check_plant(name):
    check_plant(_plant(name))


@pytest.mark.parametrize("name", sorted(FAILURE_MODELS))
def test_every_registered_failure_model_passes_check_failure_model(name):
    settings = FAILURE_SETTINGS.get(name, {})
    check_failure_model(FAILURE_MODELS[name](actuator=1, onset=1.0, **settings))
    check_failure_model(FAILURE_MODELS[name](actuator=2, onset=0.5, recovery=2.0, **settings))


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_every_registered_design_passes_check_design(name):
    loop, solver = _design_loop(name)
    check_design(loop.controller, loop, solver)


def test_position_limit_with_one_infinite_bound_is_a_valid_failure():
    """Regression (found by check_failure_model): an infinite bound was written as 1e300, a
    literal the expression language refuses, so PositionLimit(lower=-1) could not be built."""
    check_failure_model(PositionLimit(actuator=1, lower=-1.0))
    check_failure_model(PositionLimit(actuator=1))
    f = PositionLimit(actuator=1, upper=0.5).expression(("t", "u"))
    np.testing.assert_array_equal(f(t=0.0, u=np.array([-1e6, 0.2, 0.9])), [-1e6, 0.2, 0.5])


def _divide_by_position(t, x, u, p, xdot):
    xdot[0] = x[1]
    xdot[1] = u[0] / x[0]


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Exploding(Plant):
    """A plant whose equations divide by a state that is zero at the origin, and whose
    numbers are a plain tuple."""

    name: ClassVar[str] = "exploding"
    state_names: ClassVar[tuple[str, ...]] = ("p", "q")
    output_names: ClassVar[tuple[str, ...]] = ("p",)
    position_index: ClassVar[tuple[int, ...]] = (0,)
    velocity_index: ClassVar[tuple[int, ...]] = (1,)
    equations = staticmethod(_divide_by_position)

    @property
    def n_actuators(self) -> int:
        return 1

    def parameter_values(self) -> tuple:
        return (1.0,)


def test_check_plant_lists_every_problem_of_a_broken_plant():
    with pytest.raises(ConfigurationError) as info:
        check_plant(_Exploding())
    text = str(info.value)
    assert "Plant 'exploding' fails its checks (2)" in text
    assert "finite dx/dt" in text and "NamedTuple" in text


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Overrated(LossOfEffectiveness):
    model: ClassVar[str] = "overrated"

    def severity(self, scales=None) -> float:
        return 2.0


def test_check_failure_model_reports_a_severity_outside_0_1_and_a_bad_output():
    with pytest.raises(ConfigurationError, match=r"severity\(None\) must be a float in \[0, 1\]"):
        check_failure_model(_Overrated(actuator=1))
    with pytest.raises(ConfigurationError, match="is not finite"):
        check_failure_model(NonAffine(actuator=1, output="1/(u - u)"))
    with pytest.raises(ConfigurationError, match="needs a Failure instance"):
        check_failure_model(Stuck)  # the class, not a failure


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Unnamed(DirectAdaptive):
    design: ClassVar[str] = ""

    def gains(self):  # a plain tuple: numbers by position
        return (self.gamma, math.inf)


def test_check_design_reports_unnamed_numbers_and_a_missing_name():
    loop, _ = _design_loop("direct")
    ctrl = loop.controller
    bad = _Unnamed(**{f.name: getattr(ctrl, f.name) for f in dataclasses.fields(_Unnamed)})
    with pytest.raises(ConfigurationError) as info:
        check_design(bad, loop)
    text = str(info.value)
    assert "non-empty class attribute `design`" in text and "typing.NamedTuple" in text


@pytest.mark.parametrize("name", sorted(set(PLANTS) - {"equations"}))
def test_display_units_are_the_plants_own_units(name):
    """Regression: _units.py spelled units apart from the plants (the pendulum had none, the
    spacecraft's modal states disagreed once); every state's displayed unit is the plant's."""
    plant = _plant(name)
    assert len(plant.units) == plant.n_states
    for state, unit in zip(plant.state_names, plant.units, strict=True):
        assert state_unit({"plant": name}, state) == display(unit), state
    assert actuator_unit({"plant": name}) == display(plant.actuator_units)


# ----------------------------------------------------------------------- severity


def test_severity_is_the_models_own_rating():
    assert LossOfEffectiveness(actuator=1, effectiveness=0.25).severity() == 0.75
    assert math.isnan(LossOfEffectiveness(actuator=1, effectiveness="exp(-t)").severity())
    assert Stuck(actuator=1, value=0.3).severity() == 1.0
    assert Bias(actuator=1, bias=-0.05).severity({"bias": 0.1}) == 0.5
    assert math.isnan(Bias(actuator=1, bias=0.05).severity())  # no scale: not rated
    assert math.isnan(NonAffine(actuator=1, output="u**3").severity())


def test_campaign_sampling_names_no_failure_model():
    """Regression: campaigns/sampling.py rated severity by hard-coded model names."""
    from adaptive_ftc.campaigns import sampling

    source = inspect.getsource(sampling)
    assert not [name for name in FAILURE_MODELS if f'"{name}"' in source]
