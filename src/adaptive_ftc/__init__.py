"""adaptive-ftc: adaptive actuator-failure compensation, reproducing and extending the thesis.

Public API (see the README for a tour)::

    from adaptive_ftc import load_scenario, simulate
    result = load_scenario("hypersonic-direct-s1").run()
    result.to_xarray()

Every public name is imported on first use (PEP 562 ``__getattr__``), so that ``import
adaptive_ftc`` and the ``aftc`` command line (``aftc --help``, argument errors) do not pay for
numpy, the compiler or pandas until a name that needs them is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from adaptive_ftc._lazy import lazy_attributes
from adaptive_ftc._version import __version__

if TYPE_CHECKING:
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

#: ``{public name: module that defines it}``, imported on first use
_LAZY: dict[str, str] = {
    "FuzzyBasis": "adaptive_ftc.approximators",
    "LinearRegressor": "adaptive_ftc.approximators",
    "fixed_gain": "adaptive_ftc.baselines",
    "load_campaign": "adaptive_ftc.campaigns",
    "run_campaign": "adaptive_ftc.campaigns",
    "DirectAdaptive": "adaptive_ftc.controllers",
    "FailureEstimation": "adaptive_ftc.controllers",
    "MimoDirectAdaptive": "adaptive_ftc.controllers",
    "NussbaumAdaptive": "adaptive_ftc.controllers",
    "SignEstimation": "adaptive_ftc.controllers",
    "ConfigurationError": "adaptive_ftc.errors",
    "DivergenceWarning": "adaptive_ftc.errors",
    "ExpressionError": "adaptive_ftc.errors",
    "ScenarioError": "adaptive_ftc.errors",
    "Expression": "adaptive_ftc.expressions",
    "Affine": "adaptive_ftc.faults",
    "Bias": "adaptive_ftc.faults",
    "FailureSchedule": "adaptive_ftc.faults",
    "LossOfEffectiveness": "adaptive_ftc.faults",
    "NonAffine": "adaptive_ftc.faults",
    "ParameterisedStuck": "adaptive_ftc.faults",
    "PositionLimit": "adaptive_ftc.faults",
    "Reversal": "adaptive_ftc.faults",
    "Stuck": "adaptive_ftc.faults",
    "check_compensability": "adaptive_ftc.faults",
    "FlexibleSpacecraft": "adaptive_ftc.plants",
    "HypersonicAngleOfAttack": "adaptive_ftc.plants",
    "TwoLinkManipulator": "adaptive_ftc.plants",
    "WingRock": "adaptive_ftc.plants",
    "Scenario": "adaptive_ftc.scenarios.loader",
    "list_scenarios": "adaptive_ftc.scenarios.loader",
    "load_scenario": "adaptive_ftc.scenarios.loader",
    "ClosedLoop": "adaptive_ftc.sim",
    "SimResult": "adaptive_ftc.sim",
    "SolverOptions": "adaptive_ftc.sim",
    "simulate": "adaptive_ftc.sim",
    "iter_simulate": "adaptive_ftc.sim.batch",
    "simulate_many": "adaptive_ftc.sim.batch",
    "RunStatus": "adaptive_ftc.sim.status",
    "SimulationInterrupted": "adaptive_ftc.sim.status",
    "StatusReason": "adaptive_ftc.sim.status",
}

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


#: a public name (imported from its module on first use, then cached here) or a submodule
#: (``adaptive_ftc.plots``), as if ``__init__`` had imported them eagerly
__getattr__, __dir__ = lazy_attributes(globals(), _LAZY, submodules=True)
