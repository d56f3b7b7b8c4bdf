"""MIMO direct adaptive design with actuator distribution (thesis §3.3)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers.base import AdaptiveController, _nonnegative, _positive
from adaptive_ftc.controllers.laws import theta_law
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.layout import Misc

__all__ = ["MimoDirectAdaptive"]


class MimoGains(NamedTuple):
    """Adaptation gains of (3.37)."""

    eta: float
    sigma: float


@dataclass(frozen=True, kw_only=True)
class MimoDirectAdaptive(AdaptiveController):
    """``u0_i = Pi_i(z_i)^T theta_i`` (3.26), ``u = R^T u0`` (3.14) and (3.37):
    ``theta_i' = eta Pi_i (s_i' + k_i s_i + k0_i tanh(s_i/eps0)) - eta sigma theta_i``.

    ``regressors`` has one regressor per output; a single regressor is shared by all outputs
    (each output still has its own parameters).
    """

    design: ClassVar[str] = "mimo"
    equation: ClassVar[str] = "(3.26)-(3.29), (3.37)"

    regressor: FuzzyBasis | LinearRegressor | tuple
    eta: float = 0.001
    sigma: float = 0.01

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, eta=self.eta)
        _nonnegative(type(self).__name__, sigma=self.sigma)
        regs = self.regressor if isinstance(self.regressor, tuple) else (self.regressor,)
        if not regs or not all(isinstance(r, (FuzzyBasis, LinearRegressor)) for r in regs):
            raise ConfigurationError(
                "`regressor` of MimoDirectAdaptive must be a regressor or "
                "a tuple of regressors (one per output)."
            )

    @property
    def single_output(self) -> bool:
        return False

    def regressors_for(self, p: int) -> tuple:
        """One regressor per output."""
        regs = self.regressor if isinstance(self.regressor, tuple) else (self.regressor,)
        if len(regs) == 1:
            return regs * p
        if len(regs) != p:
            raise ConfigurationError(
                f"MimoDirectAdaptive has {len(regs)} regressors but the "
                f"plant has {p} outputs; give one per output or one for "
                "all."
            )
        return regs

    def theta_gain(self) -> float:
        return float(self.eta)

    def gains(self) -> MimoGains:
        return MimoGains(float(self.eta) * self.adaptation_scale, float(self.sigma))

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        g.use("theta_law", theta_law)
        return [
            "    # adaptive laws (3.37), one per output",
            f"    misc[{int(Misc.GAIN)}] = 1.0",
            *self.theta_laws(blocks, "D.gains.eta", "D.gains.sigma", "1.0"),
        ]
