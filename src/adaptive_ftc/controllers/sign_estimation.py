"""Control-direction estimation without a Nussbaum function (thesis §4.4)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from adaptive_ftc import _codes as kernel
from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers.base import AdaptiveController, _nonnegative, _positive

__all__ = ["SignEstimation"]


@dataclass(frozen=True, kw_only=True)
class SignEstimation(AdaptiveController):
    """``u0 = Pi^T theta`` (4.47) with (4.54)-(4.55):
    ``theta' = alpha0 rho Pi q - alpha0 sigma0 theta``,
    ``rho' = -alpha1 u0 q - alpha1 sigma1 rho`` (the printed ``sigma1 theta`` is read as
    ``sigma1 rho``, SPEC §5), ``q = s' + k s + k0 tanh(s/eps0)``.
    """

    design: ClassVar[str] = "sign"
    kind: ClassVar[int] = kernel.CTRL_SIGN
    equation: ClassVar[str] = "(4.47), (4.54), (4.55)"

    regressor: FuzzyBasis | LinearRegressor
    alpha0: float = 5.0
    alpha1: float = 10.0
    sigma0: float = 0.01
    sigma1: float = 0.01
    rho0: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, alpha0=self.alpha0, alpha1=self.alpha1)
        _nonnegative(type(self).__name__, sigma0=self.sigma0, sigma1=self.sigma1)
