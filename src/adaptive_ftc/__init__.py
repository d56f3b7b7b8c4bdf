"""adaptive-ftc: adaptive actuator-failure compensation, reproducing and extending the thesis.

Public API (see the README for a tour)::

    from adaptive_ftc import load_scenario, simulate
    result = load_scenario("hypersonic-direct-s1").run()
    result.to_xarray()
"""

from adaptive_ftc._version import __version__
from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.baselines import fixed_gain
from adaptive_ftc.campaigns import load_campaign, run_campaign
from adaptive_ftc.controllers import (
    DirectAdaptive,
    FailureEstimation,
    MimoDirectAdaptive,
    NussbaumAdaptive,
    SignEstimation,
)
from adaptive_ftc.errors import (
    ConfigurationError,
    DivergenceWarning,
    ExpressionError,
    ScenarioError,
)
from adaptive_ftc.expressions import Expression
from adaptive_ftc.faults import (
    Affine,
    Bias,
    FailureSchedule,
    LossOfEffectiveness,
    NonAffine,
    ParameterisedStuck,
    PositionLimit,
    Reversal,
    Stuck,
    check_compensability,
)
from adaptive_ftc.plants import (
    FlexibleSpacecraft,
    HypersonicAngleOfAttack,
    TwoLinkManipulator,
    WingRock,
)
from adaptive_ftc.scenarios.loader import Scenario, list_scenarios, load_scenario
from adaptive_ftc.sim import ClosedLoop, SimResult, SolverOptions, simulate
from adaptive_ftc.sim.batch import iter_simulate, simulate_many
from adaptive_ftc.sim.status import RunStatus, SimulationInterrupted, StatusReason

__all__ = [
    "Affine",
    "Bias",
    "ClosedLoop",
    "ConfigurationError",
    "DirectAdaptive",
    "DivergenceWarning",
    "Expression",
    "ExpressionError",
    "FailureEstimation",
    "FailureSchedule",
    "FlexibleSpacecraft",
    "FuzzyBasis",
    "HypersonicAngleOfAttack",
    "LinearRegressor",
    "LossOfEffectiveness",
    "MimoDirectAdaptive",
    "NonAffine",
    "NussbaumAdaptive",
    "ParameterisedStuck",
    "PositionLimit",
    "Reversal",
    "RunStatus",
    "Scenario",
    "ScenarioError",
    "SignEstimation",
    "SimResult",
    "SimulationInterrupted",
    "SolverOptions",
    "StatusReason",
    "Stuck",
    "TwoLinkManipulator",
    "WingRock",
    "__version__",
    "check_compensability",
    "fixed_gain",
    "iter_simulate",
    "list_scenarios",
    "load_campaign",
    "load_scenario",
    "run_campaign",
    "simulate",
    "simulate_many",
]
