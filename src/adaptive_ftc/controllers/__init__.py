"""Controller designs of the thesis, one module per design."""

from adaptive_ftc.controllers.base import AdaptiveController
from adaptive_ftc.controllers.constraints import ConstraintAware
from adaptive_ftc.controllers.direct import DirectAdaptive
from adaptive_ftc.controllers.estimation import FailureEstimation
from adaptive_ftc.controllers.mimo import MimoDirectAdaptive
from adaptive_ftc.controllers.nominal import NominalInverse, OracleInverse
from adaptive_ftc.controllers.nussbaum import NUSSBAUM_FUNCTIONS, NussbaumAdaptive
from adaptive_ftc.controllers.sign_estimation import SignEstimation

#: Registered designs by the name used in scenario files.
DESIGNS: dict[str, type[AdaptiveController]] = {
    "direct": DirectAdaptive,
    "estimation": FailureEstimation,
    "mimo": MimoDirectAdaptive,
    "nussbaum": NussbaumAdaptive,
    "sign": SignEstimation,
    "nominal-inverse": NominalInverse,
    "oracle": OracleInverse,
}

__all__ = [
    "DESIGNS",
    "NUSSBAUM_FUNCTIONS",
    "AdaptiveController",
    "ConstraintAware",
    "DirectAdaptive",
    "FailureEstimation",
    "MimoDirectAdaptive",
    "NominalInverse",
    "NussbaumAdaptive",
    "OracleInverse",
    "SignEstimation",
]
